"""Accuracy of the measurements beyond EMVA 1288 Linear against the simulator's exact truth.

Slanted-edge MTF (ares.analysis.mtf, ISO 12233 e-SFR): the simulated edge scene (ares.sim.edge,
Gaussian PSF sigma 0.6 px, pixel aperture, 1 % crosstalk: MTF known in closed form) on a
200x64 region, one frame at edge step / noise ~50, edge angles 2-10 deg, 8 seeds each: MTF50
bias and spread against the closed-form MTF50, the mean reported SE (spread/SE near 1 means
the SE is honest), and the difference to the plain ISO 12233 implementation of tests/test_mtf.py.

Photon-counting histogram (ares.analysis.photon_counting): gain and read noise against the
simulator's truth at 0.15-0.7 e- read noise, bias, spread/SE, and photon transfer beside it.

    PYTHONPATH=. python benchmarks/bench_beyond_linear.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_mtf import FLUX, SIGMA, _edge_sensor, independent_sfr  # noqa: E402
from topic_table import publish  # noqa: E402  (benchmarks/topic_table.py, beside this script)

from ares.analysis.mtf import sfr  # noqa: E402
from ares.sim.edge import true_mtf, true_mtf50  # noqa: E402

SEEDS = 8
PC_SEEDS = 10  # photon counting: more than the 5, for a spread/SE that means something


def main() -> int:
    lines = ["# Beyond EMVA 1288 Linear: accuracy against the simulator's truth", "",
             "## Slanted-edge MTF (ISO 12233 e-SFR, `ares.analysis.mtf`)", "",
             f"200x64 region, 1 frame, edge step / noise ~50, Gaussian PSF sigma {SIGMA} px + pixel aperture + 1 % "
             f"crosstalk (closed-form MTF), {SEEDS} seeds per angle. Target: MTF50 within 2 % of truth, within 1 % of "
             "an independent implementation of the standard's steps (tests/test_mtf.py).", "",
             "| angle (deg) | true MTF50 (cy/px) | MTF50 bias (%) | MTF50 spread (%) | mean SE (%) | spread/SE "
             "| worst error (%) | vs independent, worst (%) | MTF@Nyquist true | MTF@Nyquist bias |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for ang in (2.0, 4.0, 6.0, 8.0, 10.0):
        errs, ses, ind, nyq = [], [], [], []
        for seed in range(SEEDS):
            s = _edge_sensor(ang, seed=100 + seed)
            img = s.render(1, exposure_s=0.01, photon_flux=FLUX).astype(np.float64)[0]
            t50 = true_mtf50(ang, SIGMA, s.params.crosstalk_pct)
            r = sfr(img, max_code=4095)
            errs.append(r.mtf50.value / t50 - 1)
            ses.append(r.mtf50.se / t50)
            ind.append(r.mtf50.value / independent_sfr(img) - 1)
            nyq.append(r.mtf_nyquist.value)
        e, se = np.array(errs) * 100, np.array(ses) * 100
        tn = float(true_mtf(0.5, ang, SIGMA, 1.0))
        lines.append(f"| {ang:g} | {t50:.4f} | {e.mean():+.2f} | {e.std(ddof=1):.2f} | {se.mean():.2f} | "
                     f"{e.std(ddof=1) / se.mean():.2f} | {np.abs(e).max():.2f} | {100 * np.abs(ind).max():.2f} | "
                     f"{tn:.4f} | {np.mean(nyq) - tn:+.4f} |")
    lines += _photon_counting()
    return publish("beyond_linear", lines)


def _photon_counting() -> list[str]:
    from test_photon_counting import _stacks

    from ares.analysis.photon_counting import fit_histogram, photon_transfer

    out = ["", "## Photon-counting histogram (Starkey & Fossum 2016, `ares.analysis.photon_counting`)", "",
           "128x128 pixels x 40 frames at ~1.5 e- per pixel, K = 10 DN/e-, no fixed-pattern noise, exact Poisson; "
           f"{PC_SEEDS} seeds per read noise. Target: K within 0.5 %, read noise within 3 %, spread/SE 0.7-1.3. "
           "Photon transfer (light and dark temporal variances of the same stacks) beside it.", "",
           "| read noise (e-) | K worst error (%) | K spread/SE | read noise worst error (%) | read noise spread/SE "
           "| K SE (%) histogram | K SE (%) photon transfer | K worst error (%) photon transfer "
           "| read noise worst error (%) photon transfer |", "|---|---|---|---|---|---|---|---|---|"]
    for rn in (0.15, 0.3, 0.45, 0.7):
        rows = []
        for seed in range(PC_SEEDS):
            t, light, dark = _stacks(rn, 200 + seed, frames=40, size=128)
            r, pt = fit_histogram(light), photon_transfer(light, dark)
            rows.append((r["K"].value / t["G"] - 1, r["K"].se / t["G"], r["read_noise_e"].value / rn - 1,
                         r["read_noise_e"].se / rn, pt["K"].value / t["G"] - 1, pt["K"].se / t["G"],
                         pt["read_noise_e"].value / rn - 1))
        a = np.array(rows) * 100
        if not np.all(np.isfinite(a[:, 0])):
            out.append(f"| {rn:g} | not available: {r['K'].note} | | | | | {a[:, 5].mean():.2f} | "
                       f"{np.abs(a[:, 4]).max():.2f} | {np.abs(a[:, 6]).max():.2f} |")
            continue
        out.append(f"| {rn:g} | {np.abs(a[:, 0]).max():.3f} | {a[:, 0].std(ddof=1) / a[:, 1].mean():.2f} | "
                   f"{np.abs(a[:, 2]).max():.2f} | {a[:, 2].std(ddof=1) / a[:, 3].mean():.2f} | {a[:, 1].mean():.3f} | "
                   f"{a[:, 5].mean():.2f} | {np.abs(a[:, 4]).max():.2f} | {np.abs(a[:, 6]).max():.2f} |")
    return out


if __name__ == "__main__":
    raise SystemExit(main())
