"""The scan-level ``dark_temperature`` analysis: dark current against temperature per pixel
(``ares.analysis.lowlight.arrhenius``) from the dark stages' mean and temporal-variance maps the run
keeps: each pixel's rate at each temperature (weighted slope against exposure), then its
Arrhenius fit across temperatures (E_a and ln A maps with SEs), the frame's fit, Meyer-Neldel,
regimes and hot pixels by E_a. ``ares dark-temperature RUN_DIR`` prints it and writes the maps.
Registered by importing ``ares.results``."""

from __future__ import annotations

import math

import numpy as np

from ares.results.registry import register_scan_analysis

MIN_TEMPERATURES = 3


def _e(x) -> dict:
    return x.to_dict()


def pixel_rate_maps(run) -> tuple[list[float], np.ndarray, np.ndarray, str]:
    """(temperatures C, rate maps (n_T, R, C), their SEs, unit) from the run's dark stages."""
    from ares.analysis.lowlight.arrhenius import pixel_rates
    from ares.results.analyses import _dark_groups, dark_gain

    temps, rates, ses = [], [], []
    for t, sts in sorted(((t, s) for t, s in _dark_groups(run).items() if t is not None), key=lambda x: x[0]):
        exp, means, var, nf = [], [], [], []
        for st in sts:
            arr = run.arrays(st["index"])
            if "mean" not in arr or "variance" not in arr:
                continue
            n = st["views"]["full"]["level"].get("n_frames") or 1
            exp.append(float(st["settings"].get("exposure", math.nan)))
            means.append(np.asarray(arr["mean"], np.float64))
            var.append(np.asarray(arr["variance"], np.float64))
            nf.append(n)
        if len({e for e in exp if math.isfinite(e)}) < 2:
            continue
        r, s = pixel_rates(exp, means, var, nf)
        temps.append(float(t))
        rates.append(r)
        ses.append(s)
    unit = "DN/s"
    if not temps:
        return [], np.empty((0, 0, 0)), np.empty((0, 0, 0)), unit
    rates, ses = np.stack(rates), np.stack(ses)
    k, _src = dark_gain(run)
    if k is not None and k.available and k.value > 0:
        rates, ses, unit = rates / k.value, ses / k.value, "e-/s"
    return temps, rates, ses, unit


def dark_temperature_from_maps(temps, rates, ses, unit: str, at_c: float = 0.0, frame_rates=None) -> tuple[dict, dict]:
    """(summary dict for JSON, maps) from per-pixel rate maps at each temperature."""
    from ares.analysis.lowlight import arrhenius as A

    if len(temps) < MIN_TEMPERATURES:
        return ({"status": "not available",
                 "note": f"needs dark stages at >= {MIN_TEMPERATURES} temperatures with >= 2 exposures each"}, {})
    if frame_rates is None:  # the mean of the pixels' rates; SEs from their scatter over temperature
        frame_rate, frame_se = rates.reshape(len(temps), -1).mean(1), None
    else:
        frame_rate, frame_se = frame_rates
    frame = A.frame_fit(temps, frame_rate, frame_se, ref_c=at_c, unit=unit)
    fit = A.pixel_fit(temps, rates, ses)
    fe = frame["activation_ev"]  # on the frame means' scatter: the error all pixels' E_a share
    summ = A.summarize(fit, at_c, fe.se if frame_se is not None and fe.available and math.isfinite(fe.se) else 0.0)
    summ["pixels_left_out"] = int(fit.valid.size - fit.valid.sum())  # a rate <= 0 (or not finite) at some temperature
    out = {"temperatures_c": [float(t) for t in temps], "unit": unit, "ref_c": at_c,
           "frame": {"rates": [float(r) for r in frame_rate],
                     "rates_se": None if frame_se is None else [float(r) for r in frame_se],
                     **{k: (_e(v) if hasattr(v, "to_dict") else v) for k, v in frame.items()}},
           "pixels": {k: (_e(v) if hasattr(v, "to_dict") else v) for k, v in summ.items()},
           "rate_unit": unit}
    maps = {"activation_ev": fit.activation_ev, "activation_se_ev": fit.activation_se_ev,
            "ln_prefactor": fit.ln_prefactor, "ln_prefactor_se": fit.ln_prefactor_se,
            "doubling_c": fit.doubling_c(at_c), "hot_by_activation": A.hot_by_activation(fit),
            "rates": rates, "rates_se": ses}
    return out, maps


def frame_rates(run, temps, unit: str):
    """The frame's rate and SE at each temperature from the ``dark_current`` analysis (a line
    through the frame means: its SE holds the frame-wide temporal terms a pixel average misses)."""
    from ares.results.analyses import dark_current

    key = "rate_e_per_s" if unit == "e-/s" else "rate_dn_per_s"
    by_t = {v["temperature_c"]: v for v in (dark_current(run).get("by_temperature") or {}).values()}
    r, s = [], []
    for t in temps:
        e = (by_t.get(t) or {}).get(key) or {}
        r.append(e.get("value") if e.get("value") is not None else math.nan)
        s.append(e.get("se") if e.get("se") is not None else math.nan)
    return (np.asarray(r, float), np.asarray(s, float)) if np.all(np.isfinite(s)) else None


def run_dark_temperature(run, at_c: float = 0.0) -> tuple[dict, dict]:
    """(summary, maps) of a run's dark stages."""
    temps, rates, ses, unit = pixel_rate_maps(run)
    fr = frame_rates(run, temps, unit) if len(temps) else None
    return dark_temperature_from_maps(temps, rates, ses, unit, at_c, fr)


@register_scan_analysis("dark_temperature")
def dark_temperature(run) -> dict:
    return run_dark_temperature(run)[0]


RTN_MIN_FRAMES = 100
RTN_MAP_MAX = 20000  # RTN pixels listed in scan_results.json for the report's map


def _stage_frames(run, st):
    """An iterable over the raw dark frames of stage ``st`` (``<output raw_frames="true">``), or None."""
    import h5py

    if run.dir is None:
        return None
    path = run.dir / "frames" / f"{st['index']:04d}.h5"
    if not path.is_file():
        return None

    class _Frames:
        def __init__(self):
            with h5py.File(path, "r") as f:
                self.n = f["frames"].shape[0] if "frames" in f else 0

        def __iter__(self):
            with h5py.File(path, "r") as f:
                ds = f["frames"]
                for i in range(ds.shape[0]):
                    yield ds[i]

    fr = _Frames()
    return fr if fr.n else None


@register_scan_analysis("rtn")
def rtn(run) -> dict:
    """Random telegraph noise over the longest dark stage whose raw frames the run kept."""
    from ares.analysis.lowlight import rtn as R

    best = None
    for st in run.stages:
        if st["scene"] != "dark":
            continue
        fr = _stage_frames(run, st)
        if fr is not None and (best is None or fr.n > best[1].n):
            best = (st, fr)
    if best is None:
        return {"status": "not available", "note": "no dark stage's raw frames in the run (RTN needs the time "
                                                   "series: <output raw_frames=\"true\"/>)"}
    st, fr = best
    if fr.n < RTN_MIN_FRAMES:
        return {"status": "not available", "note": f"the longest dark stage holds {fr.n} frames; RTN needs >= "
                                                   f"{RTN_MIN_FRAMES}"}
    mp = R.MeanPass()
    for f in fr:
        mp.add(f)
    sc = R.Screen(mp.mean)
    for f in fr:
        sc.add(f)
    cand = sc.candidates()
    se = R.Series(mp.mean, cand)
    for f in (fr if cand.size else ()):
        se.add(f)
    px = R.fit_levels(se.series if cand.size else np.zeros((fr.n, 0)), cand)
    summ = R.summarize(px, sc.variance, mp.mean.shape)
    out = {"stage": st["name"]}
    if px.index.size <= RTN_MAP_MAX:  # the RTN map for the report (ares rtn --hdf5 writes it for any count)
        r, c = np.divmod(px.index, mp.mean.shape[1])
        out["map"] = {"shape": [int(x) for x in mp.mean.shape], "rows": r.tolist(), "cols": c.tolist(),
                      "amplitude": [round(float(a), 4) for a in px.amplitude_dn]}
    for k, v in summ.items():
        if isinstance(v, np.ndarray):
            continue
        out[k] = v.to_dict() if hasattr(v, "to_dict") else (list(v) if isinstance(v, tuple) else v)
    return out


@register_scan_analysis("fe55")
def fe55(run) -> dict:
    """The Fe-55 gain from the dark stages whose raw frames the run kept, at each stage's
    temperature setting (the electron yield depends on it; a stage without one is left out)."""
    from ares.analysis.lowlight import fe55 as X

    out = {}
    for st in run.stages:
        if st["scene"] != "dark":
            continue
        fr = _stage_frames(run, st)
        if fr is None:
            continue
        t = st["settings"].get("temperature")
        if t is None:
            out[st["name"]] = {"status": "not available", "note": "the stage sets no temperature: the electron "
                                                                  "yield of the K-alpha line depends on it"}
            continue
        ev = X.find_events(fr)
        r = X.analyse(ev.signal_dn, float(t), ev, threshold_sigma=X.THRESHOLD_SIGMA)
        out[st["name"]] = {k: (v.to_dict() if hasattr(v, "to_dict") else
                               (None if isinstance(v, float) and not math.isfinite(v) else
                                (list(v) if isinstance(v, tuple) else v)))
                           for k, v in r.items() if not k.startswith("_")}
        x, h, m = r["_fit"].hist
        if len(x):  # the fitted histogram for the report page (ares.report.fe55_page)
            out[st["name"]]["histogram"] = {"centres_dn": [round(float(v), 3) for v in x],
                                            "counts": [int(v) for v in h],
                                            "model": [round(float(v), 3) for v in m]}
    if not out:
        return {"status": "not available", "note": "no dark stage's raw frames in the run (the events need the frames: "
                                                   "<output raw_frames=\"true\"/>)"}
    return {"stages": out}
