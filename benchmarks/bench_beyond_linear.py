"""Accuracy of the measurements beyond EMVA 1288 Linear against the simulator's exact truth.

Slanted-edge MTF (ares.analysis.optics.mtf, ISO 12233 e-SFR): the simulated edge scene (ares.sim.edge,
Gaussian PSF sigma 0.6 px, pixel aperture, 1 % crosstalk: MTF known in closed form; the
simulator's default 1 % PRNU and read noise on top), edge angles 2-10 deg, 20 seeds each, at
the issue's SNR 50: the edge step over the bright side's shot noise in ONE frame is 48. Four
configurations: the standard (whole region binned) and the option ``esf_half_width=16``, each
on one frame of a 200x64 region and on the mean of 8 frames of the 200x128 array
scans/mtf.xml uses. Per configuration and angle: MTF50 bias, spread, worst error against the
closed-form MTF50, the mean reported SE (spread/SE near 1: the SE is honest), the
``edge_step_snr`` the analysis reports for the analysed image, and for the standard the
difference to the independent ISO 12233 implementation of tests/test_mtf.py on the same images.

Photon-counting histogram (ares.analysis.optics.photon_counting): gain and read noise against the
simulator's truth at 0.15-0.45 e- read noise, 5 seeds (the issue's check) and many seeds (the
SE's honesty), photon transfer on the same stacks beside it, and at 0.45 e- the same fit on
stacks drawn with numpy alone (Poisson electrons + Gaussian read noise, rounded) as the
reference for what spread/SE the fit gives on data that are exactly its model.

    PYTHONPATH=. python benchmarks/bench_beyond_linear.py
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from machine_load import Window  # noqa: E402
from test_mtf import FLUX, SIGMA, independent_sfr  # noqa: E402
from topic_table import publish  # noqa: E402  (benchmarks/topic_table.py, beside this script)

from ares.analysis.optics.mtf import LOW_NOISE_HALF_WIDTH, sfr  # noqa: E402
from ares.sim.edge import true_mtf, true_mtf50  # noqa: E402
from ares.sim.params import SensorParams  # noqa: E402
from ares.sim.sensor import SimSensor  # noqa: E402

SEEDS = 20
MTF_CONFIGS = (  # (label, esf_half_width, rows, cols, frames averaged)
    ("standard, 1 frame, 200x64", None, 200, 64, 1),
    (f"option esf_half_width={LOW_NOISE_HALF_WIDTH:g}, 1 frame, 200x64", LOW_NOISE_HALF_WIDTH, 200, 64, 1),
    ("standard, mean of 8 frames, 200x128 (scans/mtf.xml)", None, 200, 128, 8),
    (f"option esf_half_width={LOW_NOISE_HALF_WIDTH:g}, mean of 8 frames, 200x128 (scans/mtf.xml)",
     LOW_NOISE_HALF_WIDTH, 200, 128, 8),
)
PC_FEW = 5  # the check
PC_MANY = {0.15: 60, 0.25: 60, 0.35: 60, 0.45: 300}  # spread/SE known to ~9 % (60) and ~4 % (300)


def main() -> int:
    with Window() as w:
        body = _mtf() + _photon_counting()
    lines = ["# Beyond EMVA 1288 Linear: accuracy against the simulator's truth", "",
             f"Measured {w.cell()} (accuracy figures; the load does not change them).", ""]
    return publish("beyond_linear", lines + body)


def _stats(e):
    e = np.asarray(e) * 100
    return e.mean(), e.std(ddof=1), np.abs(e).max()


def _mtf() -> list[str]:
    lines = ["## Slanted-edge MTF (ISO 12233 e-SFR, `ares.analysis.optics.mtf`)", "",
             f"Edge scene: Gaussian PSF sigma {SIGMA} px + pixel aperture + 1 % crosstalk (closed-form MTF), the "
             "simulator's 1 % PRNU and read noise on top; bright side ~4000 e-, dark side ~1000 e-. **SNR definition**: "
             "the issue's SNR 50 is the edge step (~3000 e-) over the bright side's shot noise (~63 e-) in ONE frame, "
             "48 here; the column `edge_step_snr` is what the analysis reports for the image it analysed (the edge "
             "step over the robust row-to-row pixel noise of both sides, PRNU included). "
             f"{SEEDS} seeds per angle. Target: MTF50 within 2 % of the closed-form truth, within 1 % of an "
             "independent implementation of the standard's steps (`independent_sfr` in tests/test_mtf.py, written "
             "row by row from ISO 12233:2017's step list) on the same images. \"standard\": the whole region binned "
             f"(ISO 12233, the default); \"option\": `esf_half_width={LOW_NOISE_HALF_WIDTH:g}` (`ares mtf "
             "--esf-half-width 16`, `<analysis name=\"mtf\" esf_half_width=\"16\"/>`: the ESF within 16 px of the "
             "edge, less noise in the LSF window, not the standard; reported beside the standard's figures, never in "
             "their place).", "",
             "| configuration | angle (deg) | true MTF50 (cy/px) | edge_step_snr | bias (%) | spread (%) | mean SE (%) "
             "| spread/SE | worst error (%) | within 2 %? | vs independent, worst (%) | MTF@Nyquist true / bias |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    verdict = {}
    for label, hw, R, C, N in MTF_CONFIGS:
        for ang in (2.0, 4.0, 6.0, 8.0, 10.0):
            errs, ses, ind, nyq, snr = [], [], [], [], []
            for seed in range(SEEDS):
                p = SensorParams(rows=R, cols=C, illumination="slanted_edge", edge_angle_deg=ang,
                                 edge_psf_sigma_px=SIGMA).without_defects()
                s = SimSensor(p, seed=100 + seed)
                img = s.render(N, exposure_s=0.01, photon_flux=FLUX).astype(np.float64).mean(axis=0)
                t50 = true_mtf50(ang, SIGMA, s.params.crosstalk_pct)
                r = sfr(img, max_code=4095, esf_half_width=hw)
                errs.append(r.mtf50.value / t50 - 1)
                ses.append(r.mtf50.se / t50)
                snr.append(r.step_snr)
                nyq.append(r.mtf_nyquist.value)
                if hw is None:
                    ind.append(r.mtf50.value / independent_sfr(img) - 1)
            (b, sp, wo), se = _stats(errs), 100 * np.mean(ses)
            tn = float(true_mtf(0.5, ang, SIGMA, 1.0))
            verdict.setdefault(label, []).append(wo < 2.0)
            lines.append(f"| {label} | {ang:g} | {t50:.4f} | {np.mean(snr):.0f} | {b:+.2f} | {sp:.2f} | {se:.2f} | "
                         f"{sp / se:.2f} | {wo:.2f} | {'yes' if wo < 2.0 else 'no'} | "
                         f"{f'{100 * np.abs(ind).max():.2f}' if ind else '-'} | {tn:.4f} / {np.mean(nyq) - tn:+.4f} |")
    lines += ["", "Which configuration meets MTF50 within 2 % at SNR 50 (every angle, every seed): "
              + "; ".join(f"{k}: {'yes' if all(v) else 'no'}" for k, v in verdict.items()) + ". The standard's "
              "noise-free bias is -0.45 % (200x64) to -0.53 % (200x128): ISO 12233's quarter-pixel bins average the "
              "ESF over their width and nothing corrects for it; the rest of its error is the noise its full-length "
              "LSF window lets in from the ESF's flat tails: on the 200x128 array that window spans 128 px, and the "
              "simulator's 1 % PRNU does not average away over frames, so the standard's spread stays near 1 % on "
              "the 8-frame mean. The 8-frame rows are the scan's configuration: the mean of the stage's 8 frames is "
              "analysed (its `edge_step_snr` ~120)."]
    return lines


def _pc_rows(rn: float, seeds, source: str = "sim") -> np.ndarray:
    """Per seed: K and read-noise relative errors and relative SEs of the histogram fit, then
    of photon transfer, in %. ``source`` "numpy": the stacks drawn with numpy alone."""
    from test_photon_counting import H_E, _stacks

    from ares.analysis.optics.photon_counting import fit_histogram, photon_transfer

    rows = []
    for seed in seeds:
        if source == "sim":
            t, light, dark = _stacks(rn, seed, frames=40, size=128)
            G = t["G"]
        else:  # the fit's own model, drawn independently of the simulator
            G, rng = 10.0, np.random.default_rng(seed)
            light = np.rint(100 + G * rng.poisson(H_E, (40, 128, 128)) + G * rn * rng.standard_normal((40, 128, 128)))
            dark = np.rint(100 + G * rn * rng.standard_normal((40, 128, 128)))
        r, pt = fit_histogram(light), photon_transfer(light, dark)
        rows.append((r["K"].value / G - 1, r["K"].se / G, r["read_noise_e"].value / rn - 1, r["read_noise_e"].se / rn,
                     pt["K"].value / G - 1, pt["K"].se / G, pt["read_noise_e"].value / rn - 1,
                     pt["read_noise_e"].se / rn))
    return 100 * np.array(rows)


def _ratio(err, se) -> tuple[float, float]:
    """spread / mean SE and its standard error from 2000 bootstrap resamples of the seeds (no
    normality assumed: a heavy tail widens it)."""
    rng = np.random.default_rng(0)
    idx = rng.integers(0, len(err), (2000, len(err)))
    boot = err[idx].std(axis=1, ddof=1) / se[idx].mean(axis=1)
    return float(err.std(ddof=1) / se.mean()), float(boot.std(ddof=1))


def _photon_counting() -> list[str]:
    from ares.analysis.optics.photon_counting import READ_NOISE_LIMIT_E

    out = ["", "## Photon-counting histogram (Starkey & Fossum 2016, `ares.analysis.optics.photon_counting`)", "",
           "128x128 pixels x 40 frames at ~1.5 e- per pixel, K = 10 DN/e-, no fixed-pattern noise, exact Poisson. "
           "Target: K within 0.5 %, read noise within 3 % at 0.15-0.45 e- across 5 seeds, spread/SE 0.7-1.3. "
           "Photon transfer (the light and dark temporal variances of the same stacks) beside it: its SE over the "
           f"histogram's says how much better the histogram does. Above ~{READ_NOISE_LIMIT_E:g} e- the electron "
           "peaks are not separated and the verdict says so.", "",
           f"### The issue's check: {PC_FEW} seeds (0-{PC_FEW - 1}) per read noise", "",
           "| read noise (e-) | K worst (%) | read noise worst (%) | K SE (%): histogram / photon transfer "
           "| read noise SE (%): histogram / photon transfer | photon transfer worst (%): K / read noise |",
           "|---|---|---|---|---|---|"]
    for rn in (0.15, 0.25, 0.35, 0.45, 0.7):
        if rn > READ_NOISE_LIMIT_E:  # the verdict, and photon transfer alone
            from test_photon_counting import _stacks

            from ares.analysis.optics.photon_counting import fit_histogram, photon_transfer

            note, pts = "", []
            for seed in range(PC_FEW):
                t, light, dark = _stacks(rn, seed, frames=40, size=128)
                note, pt = fit_histogram(light)["K"].note, photon_transfer(light, dark)
                pts.append((pt["K"].value / t["G"] - 1, pt["K"].se / t["G"], pt["read_noise_e"].value / rn - 1,
                            pt["read_noise_e"].se / rn))
            p = 100 * np.array(pts)
            out.append(f"| {rn:g} | not available: {note} | | - / {p[:, 1].mean():.2f} | - / {p[:, 3].mean():.2f} | "
                       f"{np.abs(p[:, 0]).max():.2f} / {np.abs(p[:, 2]).max():.2f} |")
            continue
        a = _pc_rows(rn, range(PC_FEW))
        out.append(f"| {rn:g} | {np.abs(a[:, 0]).max():.3f} | {np.abs(a[:, 2]).max():.2f} | {a[:, 1].mean():.3f} / "
                   f"{a[:, 5].mean():.2f} | {a[:, 3].mean():.2f} / {a[:, 7].mean():.2f} | "
                   f"{np.abs(a[:, 4]).max():.2f} / {np.abs(a[:, 6]).max():.2f} |")
    out += ["", "### The SEs' honesty: many seeds (1000 on; the stacks drawn by numpy alone beside the simulator's "
            "at 0.45 e-)", "",
            "spread/SE: the estimates' spread over the seeds divided by the mean reported SE, +- its bootstrap SE "
            "over the seeds; max |z|: the largest |error| / own SE.", "",
            "| read noise (e-) | stacks | seeds | K bias (%) | K worst (%) | K spread/SE | K max abs z "
            "| read noise bias (%) | read noise worst (%) | read noise spread/SE | read noise max abs z "
            "| SE (%) K / read noise: histogram | photon transfer |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for rn, n in PC_MANY.items():
        for source in (("sim", "numpy") if rn == 0.45 else ("sim",)):
            a = _pc_rows(rn, range(1000, 1000 + n), source)
            kr, kse = _ratio(a[:, 0], a[:, 1])
            rr, rse = _ratio(a[:, 2], a[:, 3])
            out.append(f"| {rn:g} | {'simulator' if source == 'sim' else 'numpy (the model)'} | {n} | "
                       f"{a[:, 0].mean():+.3f} | {np.abs(a[:, 0]).max():.3f} | {kr:.2f} +- {kse:.2f} | "
                       f"{np.abs(a[:, 0] / a[:, 1]).max():.1f} | {a[:, 2].mean():+.2f} | {np.abs(a[:, 2]).max():.2f} | "
                       f"{rr:.2f} +- {rse:.2f} | {np.abs(a[:, 2] / a[:, 3]).max():.1f} | "
                       f"{a[:, 1].mean():.3f} / {a[:, 3].mean():.2f} | {a[:, 5].mean():.2f} / {a[:, 7].mean():.2f} |")
    out += ["", "At 0.45 e- the K SE of these stacks is ~0.17 %, so the 0.5 % target is ~3 SEs: over hundreds of "
            "seeds a few land just past it, on the simulator's stacks and on numpy's alike (the stack size, not the "
            "estimator; 2x the values would keep 0.5 % at 4 SEs). The read-noise spread/SE of 1.20 +- 0.09 an "
            "earlier run found on seeds 200-319 is not reproduced on these: that set held one seed 3.9 SEs out."]
    return out


if __name__ == "__main__":
    raise SystemExit(main())
