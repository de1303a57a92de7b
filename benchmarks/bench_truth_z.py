"""Never a wrong "ok" (issue 48): every shipped scan with a simulator truth, run through the
real Runner (``tests/test_scan_truth._run``, in-process) at several ``--frames`` and seeds;
per figure the z = (value - truth) / SE distribution and the count of figures reported "ok"
more than 3 SE from their truth.

The truths are the ones the truth tests use (``tests/test_scan_truth.py``: ``_ptc_k``,
``_emva_dark_var``, ``_full_well_e``, ...; the other scans' from ``SimSensor.truth()`` and the
scan's sensor parameters, as their tests take them); rtn's per pixel (``_rtn_pixel_var``, the
traps' amplitudes and dwells: ``--frames`` of 100 and more, e.g. ``--frames 500,default``);
emva_4's DSNU1288/PRNU1288 from the text's own split of the sensor's expected images
(``ares.sim.expected``). A figure whose SE covers its truth
gives z of mean ~0 and SD ~1; an SD well above 1 is an SE smaller than the figure's scatter.

    python benchmarks/bench_truth_z.py [--scans dark_current,lag] [--frames 2,4,16,default]
                                       [--seeds 8] [--rows FILE.jsonl] [--table-only]

The whole sweep (every scan, 8 seeds) takes about an hour on a shared 2-core machine (most of
it photon_transfer, gain and emva_4 at 16 frames); ``--scans`` runs a part, ``--first-seed``
adds seeds to a cell.

Each run's rows (scan, frames, seed, figure, value, SE, truth, verdict) are appended to
``--rows`` (default ``benchmarks/truth_z_rows.jsonl``, not kept in git) so that runs can be
added scan by scan; the table is rebuilt from all rows and written to ``truth_z.md`` (the
part of that file from its "## Before and after" heading on is kept: hand-written rows of
the fixes this study led to). With another ``--rows`` file the table is only printed.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
# --code DIR: the ares and tests of another tree (an earlier commit, exported), for "before" rows
_CODE = Path(sys.argv[sys.argv.index("--code") + 1]).resolve() if "--code" in sys.argv else HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(_CODE / "tests"))
sys.path.insert(0, str(_CODE))
ROOT = HERE.parent

from bench_ptc_sim import _Tmp  # noqa: E402  (pytest's tmp_path_factory stand-in for test_scan_truth._run)

KEEP = "## Before and after"
_LAST = [""]  # the scan run_one ran last (its run directory: test_scan_truth.RUN_DIRS)


def _est(d) -> dict:
    """value, se, verdict of a figure dict (an Estimate as the results write it)."""
    if not isinstance(d, dict):
        return {"value": float(d), "se": None, "verdict": "ok"}
    return {"value": d.get("value"), "se": d.get("se"), "verdict": d.get("verdict", "ok" if d.get("value") is not None else "not available")}


# ----------------------------------------------------------------------- the figures per scan
def fig_photon_transfer(scan, bench, res, stages):
    from test_scan_truth import RUN_DIRS, _emva_dark_var, _full_well_e, main_job_truth, ptc_good_pixels

    p = res["ptc"]
    t, shape, F, k = main_job_truth(scan, bench, res, stages)
    real = t["realized"]
    good = ptc_good_pixels(res, stages, RUN_DIRS[_LAST[0]])  # the defect pixels' noise where the PTC kept them
    out = [("K [DN/e-]", p["gain_dn_per_e"], k),
           ("read noise [DN]", p["read_noise_dn"], math.sqrt(_emva_dark_var(t, shape, F, good) + 1 / 12)),
           ("read noise [e-]", p["read_noise_e"], math.sqrt(_emva_dark_var(t, shape, F, good)) / t["G"]),
           ("full well [e-]", p["full_well_e"], _full_well_e(t, k))]
    d = res["decomposition"]
    for c in ("Ps", "Cs", "Rs"):
        out.append((f"masked {c} [DN^2]", d["components"][c], real[c]))
    return out


def fig_ptc_exposure(scan, bench, res, stages):
    from test_scan_truth import _full_well_e, _ptc_k, _truth

    t = _truth(scan, bench, stages[len(stages) // 2]["settings"])
    p = res["ptc"]
    k = _ptc_k(t, stages[len(stages) // 2]["views"]["full"]["level"]["n_frames"])
    return [("K [DN/e-]", p["gain_dn_per_e"], k), ("full well [e-]", p["full_well_e"], _full_well_e(t, k))]


def fig_dark_current(scan, bench, res, stages):
    from test_scan_truth import _ptc_k, _truth

    dark = [s for s in stages if s["scene"] == "dark"]
    t = _truth(scan, bench, dark[-1]["settings"])
    k = float(t["maps"]["dark_e_per_s"].mean())
    d = res["dark_current"]
    lit = [s for s in stages if s["scene"] == "flat"]
    tl = _truth(scan, bench, lit[len(lit) // 2]["settings"])
    out = [("K [DN/e-]", res["ptc"]["gain_dn_per_e"], _ptc_k(tl, lit[0]["views"]["full"]["level"]["n_frames"])),
           ("dark current, mean [e-/s]", d["rate_e_per_s"], k)]
    if "rate_from_variance_e_per_s" in d:
        out.append(("dark current, variance [e-/s]", d["rate_from_variance_e_per_s"], k))
    return out


def fig_temperature(scan, bench, res, stages):
    from ares.sim.from_system import sim_params

    return [("doubling temperature [C]", res["temperature"]["doubling_temperature_c"],
             sim_params(scan.system).dark_doubling_c)]


def fig_gain(scan, bench, res, stages):
    from test_scan_truth import _ptc_k, _truth, gain_split_truth

    out = []
    for g, r in res["ptc"]["by_analog_gain"].items():
        st = next(s for s in stages if f"x{s['settings']['analog_gain']:g}" == g)
        t = _truth(scan, bench, st["settings"])
        out.append((f"K {g} [DN/e-]", r["gain_dn_per_e"], _ptc_k(t, st["views"]["full"]["level"]["n_frames"])))
    gs = res["gain_split"]
    pix, chain = gain_split_truth(scan, bench, stages)
    return out + [("pixel noise [e-]", gs["pixel_noise_e"], pix), ("chain noise [DN]", gs["chain_noise_dn"], chain)]


def fig_adc_linearity(scan, bench, res, stages):
    adc = bench.info["sensor"].truth()["adc"]
    inl, dnl = np.asarray(adc["inl_lsb"]), np.asarray(adc["dnl_lsb"])
    out = []
    for name, c in res["adc_linearity"]["channels"].items():
        out += [(f"INL max {name} [LSB]", c["inl_max_lsb"], float(inl.max())),
                (f"INL min {name} [LSB]", c["inl_min_lsb"], float(inl.min())),
                (f"DNL max {name} [LSB]", c["dnl_max_lsb"], float(np.nanmax(dnl))),
                (f"DNL min {name} [LSB]", c["dnl_min_lsb"], float(np.nanmin(dnl)))]
    return out


def fig_lag(scan, bench, res, stages):
    from test_scan_truth import _truth

    by = {s["name"]: s for s in stages}
    if "cycles" not in res["lag"]:
        return [("lag (every cycle) [%]", {"value": None, "se": None, "verdict": "not available"}, math.nan)]
    return [("lag (every cycle) [%]", c["lag_pct"], 100 * _truth(scan, bench, by[name]["settings"])["lag_fraction"])
            for name, c in res["lag"]["cycles"].items()]


def fig_bias_sweep_2d(scan, bench, res, stages):
    """The dark level variance against its truth, with the SE the truth test builds (the stage
    JSON's variance has none of its own): a check of the components' SEs (Rt, Ct)."""
    from test_scan_truth import _emva_dark_var, _truth

    R, C = bench.info["sensor"].shape
    out = []
    for st in stages:
        t = _truth(scan, bench, st["settings"])
        dl = st["views"]["full"]["dark_level"]
        comp = st["views"]["full"]["components"]
        se = math.hypot(math.sqrt(2 / (dl["n_pixels"] * (dl["n_frames"] - 1))) * dl["var_dn2"],
                        comp["Rt"]["se"], comp["Ct"]["se"])
        out.append(("dark var (all points) [DN^2]", {"value": dl["var_dn2"], "se": se, "verdict": "ok"},
                    _emva_dark_var(t, (R, C), dl["n_frames"]) + 1 / 12))
    return out


def fig_photon_counting(scan, bench, res, stages):
    from test_scan_truth import _truth

    out = []
    for st in stages:
        d = res["photon_counting"]["stages"].get(st["name"])
        if d is None:
            continue
        t = _truth(scan, bench, st["settings"])
        out += [("K, histogram [DN/e-]", d["K"], t["G"]), ("read noise, histogram [e-]", d["read_noise_e"],
                                                             t["read_noise_e"]),
                ("mean signal, histogram [e-]", d["mean_e"], t["q"])]
        if isinstance(d.get("photon_transfer"), dict) and "K" in d["photon_transfer"]:
            out.append(("K, photon transfer of the stack [DN/e-]", d["photon_transfer"]["K"], t["G"]))
    return out


def fig_spectral_qe(scan, bench, res, stages):
    from ares.sim.params import SensorParams

    p = SensorParams.from_dict(dict(scan.system.simulator.params))
    r = res["spectral_qe"]
    out = [("K [DN/e-]", r["gain_dn_per_e"], p.gain_dn_per_e(1.0))]
    for key, pt in r["points"].items():
        if pt["qe"]["verdict"] == "ok" or "nm" in key and key[:-2].isdigit():
            out.append(("QE (every wavelength) [%]", pt["qe"], 100 * p.qe_at(pt["wavelength_nm"])))
    return out


def fig_mtf(scan, bench, res, stages):
    from ares.sim.edge import true_mtf, true_mtf50

    sim = scan.system.simulator.params
    ang, sig = sim["edge_angle_deg"], sim["edge_psf_sigma_px"]
    xt = sim.get("crosstalk_pct", 1.0)
    out = []
    for st in res["mtf"]["stages"].values():
        for d in st["channels"].values():
            t50 = true_mtf50(ang, sig, xt)
            out += [("MTF50, standard [cy/px]", d["mtf50_cy_per_px"], t50),
                    ("MTF at Nyquist, standard", d["mtf_at_nyquist"], float(true_mtf(0.5, ang, sig, xt))),
                    ("edge angle [deg]", d["angle_deg"], ang)]
            if "option" in d:
                out.append(("MTF50, option [cy/px]", d["option"]["mtf50_cy_per_px"], t50))
    return out


def fig_emva_4(scan, bench, res, stages):
    """EMVA 1288 4.0 Linear figures: K (the PTC truth at two-image pairs), QE (the sensor's at
    the scan's wavelength), sigma_d (the temporal dark noise of a two-image pair, /K), mu_I
    (the dark map's mean rate at the dark-current stages)."""
    from test_scan_truth import _emva_dark_var, _ptc_k, _truth

    v = res["emva4"]["values"]
    sp = next(s for s in stages if s["name"] == "spatial")
    t = _truth(scan, bench, sp["settings"])
    k = _ptc_k(t, 2)
    shape = bench.info["sensor"].shape
    dk = [s for s in stages if s["name"].startswith("dark_current")]
    td = _truth(scan, bench, dk[-1]["settings"])
    out = [("K [DN/e-]", v["K"], k), ("QE [%]", v["QE"], 60.0),
           ("sigma_d [e-]", v["sigma_d"], math.sqrt(_emva_dark_var(_truth(scan, bench, stages[0]["settings"]),
                                                                   shape, 2)) / k)]
    if isinstance(res.get("ptc"), dict) and "gain_dn_per_e" in res["ptc"]:  # the scan's own photon transfer
        out.append(("K, ptc analysis of the same levels [DN/e-]", res["ptc"]["gain_dn_per_e"], k))
    for key in ("mu_I", "mu_I_mean", "mu_I_var"):
        if key in v:
            out.append((f"{key} [e-/s]", v[key], float(td["maps"]["dark_e_per_s"].mean())))
    return out + _emva_spatial(scan, bench, v, sp["settings"], k)


def _emva_spatial(scan, bench, v: dict, settings: dict, k: float) -> list:
    """DSNU1288, PRNU1288 and parts (EMVA 1288 4.0 Linear Section 8, Eqs. 66, 67): the text's split
    (``nonuniformity.split``: the 4.0 high-pass, Eqs. 35 - 44) of the sensor's expected dark and
    50 % images (``ares.sim.expected``: no temporal noise), every pixel in; DSNU in e- by K's truth."""
    from ares.analysis.spatial.nonuniformity import split
    from ares.scan.apply import apply_settings
    from ares.sim.expected import expected_codes

    apply_settings(bench, scan.system, settings)
    s = bench.frames.settings()
    for key in ("test_mode", "streaming", "photon_flux"):
        s.pop(key)
    sensor = bench.info["sensor"]
    d = split(expected_codes(sensor, photon_flux=0.0, **s), 0.0, 1, "4.0")
    b = split(expected_codes(sensor, photon_flux=settings.get("light", 0.0), **s), 0.0, 1, "4.0")
    out = [("DSNU1288 [DN]", v.get("DSNU1288_DN"), math.sqrt(d.total))]
    for part, suffix in (("total", ""), ("col", "_col"), ("row", "_row"), ("pix", "_pix")):
        out.append((f"DSNU1288{suffix} [e-]", v.get("DSNU1288" + suffix), math.sqrt(max(d.get(part)[0], 0.0)) / k))
        out.append((f"PRNU1288{suffix} [%]", v.get("PRNU1288" + suffix),
                    100 * math.sqrt(max(b.get(part)[0] - d.get(part)[0], 0.0)) / (b.mean - d.mean)))
    return [(n, e if e is not None else {"value": None, "se": None, "verdict": "not available"}, t) for n, e, t in out]


def fig_fe55(scan, bench, res, stages):
    from test_scan_truth import _truth

    out = []
    for st in stages:
        d = res["fe55"]["stages"].get(st["name"])
        if d is not None:
            t = _truth(scan, bench, st["settings"])
            out.append(("gain, Fe-55 K-alpha [e-/DN]", d["gain_e_per_dn"], t["lowlight"]["xray"]["gain_e_per_dn"]))
    return out


def fig_dark_temperature(scan, bench, res, stages):
    """Per temperature the dark current from the mean in DN/s (the scan measures no K) against
    the dark map's mean rate x G; the median per-pixel activation energy against the median of
    the simulator's E_a map (sim_lowlight.xml: a per-pixel Arrhenius law)."""
    from test_scan_truth import _truth

    out = []
    for key, v in (res["dark_current"].get("by_temperature") or {}).items():
        st = [s for s in stages if s["settings"].get("temperature") == v.get("temperature_c")]
        if st:
            t = _truth(scan, bench, st[-1]["settings"])
            out.append(("dark current, mean, every temperature [DN/s]", v["rate_dn_per_s"],
                        float(t["maps"]["dark_e_per_s"].mean()) * t["G"]))
    px = res["dark_temperature"]["pixels"]
    t = _truth(scan, bench, stages[0]["settings"])
    out.append(("median activation energy [eV]", px["median_activation_ev"],
                float(np.median(t["lowlight"]["arrhenius"]["activation_ev"]))))
    return out


def _rtn_pixel_var(t: dict, sensor, frames: int) -> np.ndarray:
    """Per pixel the temporal variance (DN^2) of a ``frames``-frame dark stack about its mean,
    line terms apart: read (x the noisy factor), chain, dark shot noise (hot pixels too), the ADC's
    quantization (code widths w from its DNL: sum w^3 / 12 sum w), the traps' p (1 - p) A^2 x
    (1 - 2 sum_k (F - k) rho^k / (F (F - 1))), rho = 1 - P_up - P_down (a correlated series)."""
    fp = sensor.patterns
    G = t["G"]
    dark = t["maps"]["dark_e_per_s"].astype(np.float64) * t["scene"]["exposure_s"]
    var = (G * t["read_noise_e"] * fp.read_noise_factor.astype(np.float64)) ** 2 + sensor.params.chain_noise_dn ** 2
    var = var + G * G * dark
    dnl = np.asarray(t["adc"]["dnl_lsb"], float)
    c = int(round(t["o"]))
    w = 1 + np.nan_to_num(dnl[max(c - 8, 0):c + 8])
    var = var + float(np.sum(w**3) / (12 * np.sum(w)))
    idx = fp.defects.index["rts"]
    if len(idx):
        pu, pd = fp.rts_p_up.astype(np.float64), fp.rts_p_down.astype(np.float64)
        pi = pu / (pu + pd)
        rho = 1 - pu - pd
        k = np.arange(1, frames)
        shrink = 1 - 2 / (frames * (frames - 1)) * np.array([np.sum((frames - k) * r**k) for r in rho])
        amp = G * fp.defects.rts_amplitude_e.astype(np.float64)
        var.ravel()[idx] += amp**2 * pi * (1 - pi) * shrink
    return var.ravel()


def fig_rtn(scan, bench, res, stages):
    """RTN (scans/rtn.xml): the fraction of RTS pixels (the simulator's, all above 3x the noise),
    the rms temporal noise with and without the pixels called RTN and the increase
    (``_rtn_pixel_var``), the median amplitude (of every RTS pixel); per RTS pixel found, its
    amplitude and dwells against the trap's (the scan's analysis on its raw frames: ``ares rtn``)."""
    import h5py
    from test_scan_truth import RUN_DIRS, _truth

    from ares.analysis.lowlight import rtn as R

    r = res["rtn"]
    if "stage" not in r:  # fewer frames than RTN needs (RTN_MIN_FRAMES): said, not a failed run
        na = {"value": None, "se": None, "verdict": "not available", "note": r.get("note", "")}
        return [(f, na, math.nan) for f in ("RTN fraction", "temporal noise [DN]", "median amplitude [DN]")]
    st = next(s for s in stages if s["name"] == r["stage"])
    t = _truth(scan, bench, st["settings"])
    sensor = bench.info["sensor"]
    n = r["pixels"]
    var = _rtn_pixel_var(t, sensor, r["frames"])
    called = np.zeros(n, bool)
    cols = sensor.shape[1]
    called[np.asarray(r.get("map", {}).get("rows", []), int) * cols + np.asarray(r.get("map", {}).get("cols", []), int)] = True
    idx = sensor.patterns.defects.index["rts"]
    amp = t["lowlight"]["rts_amplitude_dn"]
    out = [("RTN fraction", r["rtn_fraction"], len(idx) / n),
           ("temporal noise [DN]", r["temporal_noise_dn"], math.sqrt(var.mean())),
           ("temporal noise without RTN [DN]", r["temporal_noise_without_rtn_dn"], math.sqrt(var[~called].mean())),
           ("temporal noise increase [%]", r["temporal_noise_increase_pct"],
            100 * (math.sqrt(var.mean() / var[~called].mean()) - 1)),
           ("median amplitude [DN]", r["median_amplitude_dn"], float(np.median(amp)))]
    with h5py.File(RUN_DIRS["rtn"] / "frames" / f"{st['index']:04d}.h5", "r") as f:
        px, _ = R.analyse_stack(f["frames"][()])
    where = {int(i): k for k, i in enumerate(px.index)}
    ll = t["lowlight"]
    for j, i in enumerate(idx):
        k = where.get(int(i))
        if k is None:
            continue
        for name, v, se, tr in (("amplitude, every RTS pixel found [DN]", px.amplitude_dn, px.amplitude_se_dn, amp),
                                ("dwell low, every RTS pixel found [frames]", px.dwell_low_frames, px.dwell_low_se,
                                 ll["rts_dwell_low_frames"]),
                                ("dwell high, every RTS pixel found [frames]", px.dwell_high_frames, px.dwell_high_se,
                                 ll["rts_dwell_high_frames"])):
            out.append((name, {"value": float(v[k]), "se": float(se[k]), "verdict": "ok"}, float(tr[j])))
    return out


FIGURES = {
    "photon_transfer": fig_photon_transfer, "ptc_exposure": fig_ptc_exposure, "dark_current": fig_dark_current,
    "temperature": fig_temperature, "gain": fig_gain, "adc_linearity": fig_adc_linearity, "lag": fig_lag,
    "bias_sweep_2d": fig_bias_sweep_2d, "photon_counting": fig_photon_counting, "spectral_qe": fig_spectral_qe,
    "mtf": fig_mtf, "emva_4": fig_emva_4, "fe55": fig_fe55, "dark_temperature": fig_dark_temperature,
    "photon_transfer_precision": fig_photon_transfer, "rtn": fig_rtn,
}


# ----------------------------------------------------------------------- running and the table
def run_one(scan_name: str, frames, seed: int) -> list[dict]:
    from test_scan_truth import _run

    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        scan, bench, res, stages = _run(scan_name, _Tmp(Path(d)), frames=frames, seed=seed)
        _LAST[0] = scan_name
        rows = []
        for fig, est, truth in FIGURES[scan_name](scan, bench, res, stages):
            e = _est(est)
            rows.append({"scan": scan_name, "frames": frames or "default", "seed": seed, "figure": fig,
                         "value": e["value"], "se": e["se"], "truth": float(truth), "verdict": e["verdict"],
                         "note": (est.get("note") or "")[:400] if isinstance(est, dict) else "",
                         "s": round(time.perf_counter() - t0, 1)})
    return rows


def z_of(r: dict) -> float | None:
    v, se = r["value"], r["se"]
    if v is None or se is None or not (isinstance(se, (int, float)) and math.isfinite(se) and se > 0):
        return None
    return (v - r["truth"]) / se


def _own_frames(scan: str) -> str:
    """The scan's <frames>; "" when a stage sets its own or precision targets set them (then
    --frames N is not the default)."""
    from ares.protocol import load_scan

    if re.search(r'\s(dark_)?frames="|<precision', (ROOT / "scans" / f"{scan}.xml").read_text()):
        return ""
    return str(load_scan(ROOT / "scans" / f"{scan}.xml").frames)


def table(rows: list[dict]) -> list[str]:
    groups: dict[tuple, list[dict]] = {}
    own = {s: _own_frames(s) for s in {r["scan"] for r in rows}}
    for r in rows:
        f = str(r["frames"])
        if f == "default":
            if any(str(x["frames"]) == own[r["scan"]] for x in rows if x["scan"] == r["scan"]):
                continue  # (the same runs as the numbered frame count's)
            f = f"{own[r['scan']] or 'stages own'} (default)"
        groups.setdefault((r["scan"], r["figure"], f), []).append(r)
    order = list(FIGURES) + sorted({r["scan"] for r in rows} - set(FIGURES))
    fr_key = lambda f: int(f.split()[0]) if f.split()[0].isdigit() else 10**6  # noqa: E731
    lines = ["| scan | figure | frames | n | ok | n/a | z mean | z SD | max abs z | wrong ok (ok, abs z > 3) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for key in sorted(groups, key=lambda k: (order.index(k[0]), k[1], fr_key(k[2]))):
        g = groups[key]
        ok = [r for r in g if r["verdict"] == "ok"]
        na = sum(r["verdict"] != "ok" for r in g)
        z = np.array([x for x in (z_of(r) for r in ok) if x is not None])
        wrong = int(np.sum(np.abs(z) > 3)) if z.size else 0
        seeds = len({r["seed"] for r in g})
        n_txt = f"{len(g)}" if len(g) == seeds else f"{len(g)} ({seeds} seeds)"
        zs = (f"{z.mean():+.2f} | {z.std(ddof=1):.2f} | {np.abs(z).max():.1f}" if z.size > 1 else " | | ")
        lines.append(f"| {key[0]} | {key[1]} | {key[2]} | {n_txt} | {len(ok)} | {na} | {zs} | "
                     f"{'**' + str(wrong) + '**' if wrong else 0} |")
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scans", default=",".join(FIGURES))
    ap.add_argument("--frames", default="2,4,16,default")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--rows", default=str(HERE / "truth_z_rows.jsonl"))
    ap.add_argument("--table-only", action="store_true", help="rebuild truth_z.md from the kept rows")
    ap.add_argument("--code", default=None, help="import ares and the truth tests from this tree (before rows)")
    ap.add_argument("--note", default="", help="a sentence for the table's header (the code state measured)")
    a = ap.parse_args()
    rows_path = Path(a.rows)
    if not a.table_only:
        with rows_path.open("a") as fh:
            for name in a.scans.split(","):
                own = _own_frames(name)
                for f in a.frames.split(","):
                    frames = None if f == "default" else int(f)
                    if f == "default" and own in a.frames.split(","):
                        continue  # (the default is one of the frame counts already run)
                    for sd in range(a.first_seed, a.first_seed + a.seeds):
                        try:
                            rows = run_one(name, frames, sd)
                        except Exception as exc:  # a run that fails is a row of its own, said so
                            rows = [{"scan": name, "frames": f, "seed": sd, "figure": "(the run)", "value": None,
                                     "se": None, "truth": math.nan, "verdict": f"failed: {exc}"[:200], "s": 0}]
                        for r in rows:
                            fh.write(json.dumps(r) + "\n")
                            zz = z_of(r)
                            print(f"{name} F={f} seed {sd}: {r['figure']}: {r['value']} +- {r['se']} truth "
                                  f"{r['truth']:.6g} z {'' if zz is None else f'{zz:+.2f}'} {r['verdict']}", flush=True)
                        fh.flush()
    rows = [json.loads(x) for x in rows_path.read_text().splitlines() if x.strip()] if rows_path.exists() else []
    from topic_table import publish

    md = HERE / "truth_z.md"
    kept = md.read_text().split(KEEP, 1)[1] if md.exists() and KEEP in md.read_text() else "\n"
    fixed = "Accuracy figures: the machine's load does not change them."
    if not a.note and md.exists():  # the measured state's sentence stays until a new one is given
        line = next((ln for ln in md.read_text().splitlines() if fixed in ln), "")
        a.note = line.split(fixed, 1)[1].strip() if line else ""
    head = ["# Never a wrong \"ok\": z = (value - truth) / SE of every figure with a simulator truth",
            "",
            "`benchmarks/bench_truth_z.py`: the shipped scans through the real Runner on the simulated bench "
            "(`tests/test_scan_truth._run`), at `--frames` 2, 4, 16 and the scan's default, seeds 1..n; truths "
            "as the truth tests take them (`tests/test_scan_truth.py`). A figure whose SE is right gives z of "
            "mean ~0 and SD ~1; \"wrong ok\" counts figures reported \"ok\" more than 3 SE from their truth "
            "(issue 48). n/a: the figure not available (its verdict not ok); SD over the \"ok\" ones. "
            + fixed + (" " + a.note if a.note else ""),
            ""]
    lines = head + table(rows) + ["", KEEP + kept.rstrip("\n")]
    if rows_path.resolve() != (HERE / "truth_z_rows.jsonl").resolve():  # a side study: printed, truth_z.md kept
        print("\n".join(lines))
        return 0
    return publish("truth_z", lines)


if __name__ == "__main__":
    sys.exit(main())
