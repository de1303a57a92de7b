"""Built-in scan-level analyses, registered with ``ares.results.registry.register_scan_analysis``.

Each takes a ``RunRecord`` (scan + stage results) and returns a JSON-able dict of
``Estimate.to_dict()`` values. They adapt stage results to the characterization
module (``ares.analysis.ptc.photon_transfer`` ...); the numbers are computed there.
"""

from __future__ import annotations

import math
import warnings

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.physical import resolved, variances_in_range
from ares.results.registry import register_scan_analysis


def _levelstats(level: dict):
    from ares.analysis.ptc.levels import LevelStats

    nan = math.nan
    return LevelStats(level["mean_dn"], level["var_dn2"] if level["var_dn2"] is not None else nan,
                      level["n_pixels"], level["n_frames"], level["frac_at_max"], level["frac_at_min"],
                      level["spatial_var_dn2"] if level.get("spatial_var_dn2") is not None else nan)


def _e(x: Estimate) -> dict:
    return x.to_dict()


def _ptc_groups(run) -> dict:
    """Flat stages with a matched dark, grouped by analog gain (one PTC per gain); a
    wavelength sweep's stages are spectral points, not levels (``spectral_groups``)."""
    from ares.analysis.optics.spectral_qe import spectral_groups

    groups: dict = {}
    spectral = spectral_groups(run.stages)
    for st in run.stages:
        full = st["views"]["full"]
        if st["scene"] != "flat" or "dark_level" not in full or st["group"] in spectral:
            continue
        groups.setdefault(st["settings"].get("analog_gain", 1.0), []).append(st)
    return groups


def _adc_lsb_uv(system):
    sim = system.simulator
    if sim is not None:
        if "adc_lsb_uv" in sim.params:
            return float(sim.params["adc_lsb_uv"])
        from ares.sim import SensorParams

        return float(SensorParams().adc_lsb_uv)
    return None


def signal_se(stage: dict) -> float:
    """SE (DN) of a flat stage's mean from the scatter of its frame means: the frame-global
    offset and the row/column temporal terms move the mean of every frame. The matched
    dark's share is common to the levels that reuse it (absorbed by the fit's intercept)
    and is left out."""
    fm = stage["views"]["full"]["level"].get("frame_means") or []
    if len(fm) < 2:
        return math.nan
    m = sum(fm) / len(fm)
    return math.sqrt(sum((x - m) ** 2 for x in fm) / (len(fm) - 1) / len(fm))


def _read_noise_with_line_terms(r, stages: list, components: str = "components", dark=None):
    """Read noise with an honest SE: the stack variance's sqrt(2/dof) counts every pixel
    as independent, but its row and column temporal parts (Rt, Ct) are sampled by only
    rows x frames and cols x frames draws: the dark ANOVA's (``components``: the view the
    levels were read from, masked or not) SEs of Rt and Ct are added. From one dark level
    (``dark``: the matched dark every level reuses) the variance's SE is the ANOVA's whole:
    its white part Pt's chi-square on n_pixels (F - 1) dof with those of Rt and Ct -- not
    the whole variance's as if white, which counts the row and column parts twice."""
    dn, e = r.read_noise_dn, r.read_noise_e
    full = stages[0]["views"]["full"] if stages else {}
    comp = full.get(components) or full.get("components", {})  # (an older run: no masked components)
    extra = [comp.get(k, {}).get("se") for k in ("Rt", "Ct")]
    extra = [x for x in extra if x is not None and math.isfinite(x)]
    if not extra or not dn.available or not math.isfinite(dn.se) or r.read_noise_is_upper_limit:
        return dn, e
    s2 = dn.value**2
    s2_se = math.hypot(2 * dn.value * dn.se, *extra)
    pt = comp.get("Pt", {}).get("value")
    if dark is not None and len(extra) == 2 and pt is not None and math.isfinite(pt) and dark.dof > 0:
        s2_se = math.hypot(math.sqrt(2.0 / dark.dof) * max(pt, 0.0), *extra)
    dn2 = Estimate(dn.value, s2_se / (2 * dn.value), dn.unit, dn.note + "; SE incl. the Rt, Ct sampling")
    k = r.gain_dn_per_e
    if not e.available or not k.available:
        return dn2, e
    num = math.sqrt(max(s2 - 1.0 / 12.0, 0.0))
    se_e = math.hypot(s2_se / (2 * num) / k.value if num > 0 else math.nan, e.value * k.se / k.value)
    return dn2, Estimate(e.value, se_e, e.unit, e.note + "; SE incl. the Rt, Ct sampling")


def ptc_one(run, stages: list, analog_gain: float) -> dict:
    from ares.analysis.ptc.photon_transfer import analyze_ptc

    from ares.results.registry import ptc_level_keys

    lv, dk = ptc_level_keys(stages)  # defect pixels out where every level has masked statistics
    masked = lv == "level_masked"
    bright = [_levelstats(s["views"]["full"][lv]) for s in stages]
    dark = [_levelstats(s["views"]["full"][dk]) for s in stages]
    exp = [s["settings"].get("exposure", math.nan) for s in stages]
    light = [s["settings"].get("light") for s in stages]
    photons = [l_ * e for l_, e in zip(light, exp)] if all(v is not None for v in light) else None
    if photons is not None and len(set(photons)) < 2:
        photons = None
    r = analyze_ptc(bright, dark, exposure_s=exp if all(math.isfinite(e) for e in exp) else None,
                    photons=photons, adc_lsb_uv=_adc_lsb_uv(run.system), analog_gain=analog_gain,
                    signal_se=[signal_se(s) for s in stages])
    one = {(d.mean, d.var, d.n_pixels, d.n_frames) for d in dark}  # (as read_noise counts them)
    rn_dn, rn_e = _read_noise_with_line_terms(r, stages, "components_masked" if masked else "components",
                                              dark[0] if len(one) == 1 else None)
    out = {"analog_gain": analog_gain, "levels": len(stages),
           "defect_pixels_excluded": stages[0]["views"]["full"].get("masked_pixels", 0) if masked else 0}
    out.update(r.to_dict([s["name"] for s in stages]))
    out.update(read_noise_dn=_e(rn_dn), read_noise_e=_e(rn_e))
    return out


@register_scan_analysis("ptc")
def ptc(run) -> dict:
    groups = _ptc_groups(run)
    if not groups:
        return {"status": "not available", "note": "no flat stages with a matched dark"}
    results = {g: ptc_one(run, st, g) for g, st in groups.items() if len(st) >= 2}
    if not results:
        return {"status": "not available", "note": "needs at least 2 flat levels"}
    first = next(iter(results.values()))
    if len(results) == 1:
        return first
    out = dict(first)
    out["by_analog_gain"] = {f"x{g:g}": r for g, r in results.items()}
    return out


def mid_level_stage(run) -> dict | None:
    """The flat stage nearest half of the highest unclipped signal (else the middle stage)."""
    flats = [s for s in run.stages if s["scene"] == "flat"]
    if not flats:
        return run.stages[len(run.stages) // 2] if run.stages else None

    def signal(s):
        full = s["views"]["full"]
        return full["level"]["mean_dn"] - (full["dark_level"]["mean_dn"] if "dark_level" in full else 0.0)

    ok = [s for s in flats if s["views"]["full"]["level"]["frac_at_max"] < 0.002]
    if not ok:
        return flats[len(flats) // 2]
    top = max(signal(s) for s in ok)
    return min(ok, key=lambda s: abs(signal(s) - top / 2))


@register_scan_analysis("decomposition")
def decomposition(run) -> dict:
    st = mid_level_stage(run)
    if st is None:
        return {"status": "not available", "note": "no stages"}
    full = st["views"]["full"]
    def judged(comps: dict) -> dict:  # a variance not resolved from 0 is its upper limit, as every surface shows it
        return {k: e.to_dict() for k, e in variances_in_range({k: Estimate.from_dict(d) for k, d in comps.items()}).items()}

    out = {"stage": st["name"], "scene": st.get("scene"), "settings": st["settings"],
           "components": judged(full["components"])}
    if "components_masked" in full:
        # the headline components exclude the defect pixels (ares.scan.defect_mask); the
        # unmasked ones stay beside them
        out.update(components=judged(full["components_masked"]), components_unmasked=judged(full["components"]),
                   **{k: v for k, v in (st.get("defect_mask") or {}).items()})
    elif st.get("defect_mask"):
        out["mask_note"] = "no masked figures for this stage (its dark was taken before the defect mask)"
    return out


def _run_gain(run, analog_gain: float | None = None):
    """K (DN/e-) measured by this run's PTC, as an Estimate, or None."""
    if not _ptc_groups(run):
        return None
    try:
        p = ptc(run)
    except Exception:
        return None
    if analog_gain is not None and "by_analog_gain" in p:
        p = p["by_analog_gain"].get(f"x{analog_gain:g}", p)
    g = p.get("gain_dn_per_e")
    if not isinstance(g, dict) or g.get("value") is None:
        return None
    return Estimate(g["value"], g["se"] if g.get("se") is not None else math.nan, "DN/e-")


NO_GAIN = "the scan measures no gain; give --gain: ares report RUN --gain K"


def dark_gain(run) -> tuple[Estimate | None, str]:
    """K for dark currents in e-/s and where it came from: this run's PTC, else the gain
    given to ``ares report --gain`` (run.json ``gain_given``), else the system XML's
    ``<sensor><gain dn_per_e se source>`` (a calibration), else None and the sentence saying
    why e-/s is not available."""
    k = _run_gain(run)
    if k is not None:
        return k, "ptc in this run"
    g = (run.meta or {}).get("gain_given")
    if isinstance(g, dict) and g.get("value"):
        se = g.get("se")
        return (Estimate(float(g["value"]), math.nan if se is None else float(se), "DN/e-"),
                f"given: {g.get('text', g['value'])} ({g.get('source', 'ares report --gain')})")
    s = run.scan.system.sensor if getattr(run, "scan", None) is not None else None
    if s is not None and s.gain_dn_per_e:
        se = f" ± {s.gain_se:g}" if s.gain_se else " (no SE declared: not in the e-/s SEs)"
        return (Estimate(s.gain_dn_per_e, s.gain_se if s.gain_se else math.nan, "DN/e-"),
                f"system XML <gain>: {s.gain_dn_per_e:g}{se} DN/e-" + (f" ({s.gain_source})" if s.gain_source else ""))
    return None, "e-/s not available: " + NO_GAIN


def _dark_groups(run) -> dict:
    """Dark stages grouped by temperature (None when not set)."""
    groups: dict = {}
    for st in run.stages:
        if st["scene"] == "dark" and st["settings"].get("reg:test_mode", 0) == 0:
            groups.setdefault(st["settings"].get("temperature"), []).append(st)
    return groups


@register_scan_analysis("dark_current")
def dark_current(run) -> dict:
    from ares.analysis.ptc.dark_current import dark_current as fit, dsnu_vs_exposure
    from ares.results.dark_drift import drift_verdict as _drift_verdict, frame_times

    groups = _dark_groups(run)
    if not groups:
        return {"status": "not available", "note": "no dark stages"}
    k, source = dark_gain(run)
    out = {"gain_from": source}
    per_t = {}
    for t, sts in groups.items():
        exp = [s["settings"].get("exposure", math.nan) for s in sts]
        lv = [s["views"]["full"]["level"] for s in sts]
        dc = fit(exp, [x["mean_dn"] for x in lv], k if k is not None else math.nan, [x["var_dn2"] for x in lv],
                 frame_means=[x.get("frame_means") for x in lv], frame_times=[frame_times(s, run) for s in sts])
        ds = dsnu_vs_exposure(exp, [math.sqrt(max(x["spatial_var_dn2"] or 0.0, 0.0)) for x in lv], k)
        e_s = (dc.rate_e_per_s, dc.rate_from_variance_e_per_s, ds.dsnu_e_per_s)
        if k is None:  # beside every DN/s figure: why there is no e-/s one
            e_s = tuple(Estimate.na(NO_GAIN, "e-/s") if x.note in ("gain not available", "gain not given") else x
                        for x in e_s)
        per_t["default" if t is None else f"{t:g}C"] = {
            "temperature_c": t, "rate_dn_per_s": _drift_verdict(_e(dc.rate_dn_per_s), dc.drift),
            "rate_e_per_s": _drift_verdict(_e(e_s[0]), dc.drift),
            "rate_from_variance_e_per_s": _e(e_s[1]), "offset_dn": _e(dc.offset_dn),
            "dsnu_dn_per_s": _e(ds.dsnu_dn_per_s), "dsnu_e_per_s": _e(e_s[2])}
        if dc.drift is not None and dc.drift.kept:  # the offset's drift the frames show (one not seen: the note)
            per_t["default" if t is None else f"{t:g}C"]["offset_drift_dn_per_s"] = _e(Estimate(
                dc.drift.drift, dc.drift.drift_se, "DN/s", f"drift of the dark mean with clock time (F-test p "
                f"{dc.drift.p:.2g}), fitted beside the rate"))
    if len(per_t) == 1:
        out.update(next(iter(per_t.values())))
    else:
        out["by_temperature"] = per_t
    return out


@register_scan_analysis("temperature")
def temperature(run) -> dict:
    from ares.analysis.ptc.dark_current import _div, doubling_temperature

    dc = dark_current(run)
    by_t = dc.get("by_temperature")
    if not by_t:
        return {"status": "not available", "note": "needs dark stages at >= 3 temperatures"}
    rows = [(v["temperature_c"], v["rate_dn_per_s"]) for v in by_t.values() if v["temperature_c"] is not None]
    T = [t for t, r in rows]
    vals = [r["value"] if r["value"] is not None else math.nan for t, r in rows]
    ses = [r["se"] if r["se"] is not None else math.nan for t, r in rows]
    fit = doubling_temperature(T, vals, ses if all(math.isfinite(s) for s in ses) else None)
    ref = fit.value_at_ref
    ref_dn = Estimate(ref.value, ref.se, "DN/s", ref.note) if ref.available else Estimate.na(ref.note, "DN/s")
    k, _ = dark_gain(run)  # the doubling temperature is the same in DN/s and e-/s (K is constant)
    ref_e = _div(ref_dn, k, "e-/s", f"{ref.note} / K") if k is not None and ref.available else \
        Estimate.na(NO_GAIN if ref.available else ref.note, "e-/s")
    out = {"doubling_temperature_c": _e(fit.doubling_c), "rate_at_ref_dn_per_s": _e(ref_dn),
           "rate_at_ref_e_per_s": _e(ref_e), "gain_from": dc.get("gain_from"), "ref_c": fit.ref_c,
           "temperatures_c": T}
    from ares.results.dark_drift import inherit

    return inherit(out, rows)


@register_scan_analysis("gain_split")
def gain_split(run) -> dict:
    from ares.analysis.ptc.gain_split import split_noise

    groups = _ptc_groups(run)
    ks, kses, vs, ses, gains = [], [], [], [], []
    for g, sts in groups.items():
        k = _run_gain(run, g)
        if k is None:
            continue
        d = sts[0]["views"]["full"]["dark_level"]
        ks.append(k.value)
        kses.append(k.se)
        vs.append(d["var_dn2"])
        se = math.sqrt(2.0 / (d["n_pixels"] * max(d["n_frames"] - 1, 1))) * abs(d["var_dn2"])
        comp = sts[0]["views"]["full"].get("components", {})  # Rt, Ct: sampled by rows/cols only
        extra = [comp.get(c, {}).get("se") for c in ("Rt", "Ct")]
        ses.append(math.hypot(se, *[x for x in extra if x is not None and math.isfinite(x)]))
        gains.append(g)
    r = split_noise(ks, vs, ses, gain_se=kses)
    return {"analog_gains": gains, "gain_dn_per_e": ks, "pixel_noise_e": _e(r.pixel_noise_e),
            "chain_noise_dn": _e(r.chain_noise_dn), "crossover_gain_dn_per_e": _e(r.crossover_gain_dn_per_e),
            "chi2_red": r.chi2_red}


LAG_SETTLE = 2  # frames of each stack left out as settling


def lag_cycle(fb: list, fd: list, settle: int = LAG_SETTLE):
    """Image lag of one bright->dark cycle from its frame means (the bright stack's, then
    the dark stack's right after it): (Estimate in %, bright signal in DN), or None when
    a stack has no more than ``settle`` frames."""
    import numpy as np

    from ares.analysis.ptc.lag import image_lag

    if len(fb) <= settle or len(fd) <= settle:
        return None
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # 1-pixel "images": pixel-scatter SE undefined
        r = image_lag(np.array(fb[settle:])[:, None, None], np.array([[fd[0]]]),
                      np.array(fd[settle:])[:, None, None])
    est = r.lag_pct
    if est.available and not math.isfinite(est.se) and len(fd) > settle + 1:
        # the lag is the first dark frame's mean less the mean of the m settled ones: its error
        # is one frame mean's scatter x sqrt(1 + 1/m), that scatter measured on m - 1 degrees of
        # freedom, so Student's t (issue 48: at 4 frames, 1 dof, the bare scatter gave lags up
        # to 93 SE from the simulator's truth, "ok"; benchmarks/truth_z.md)
        from ares.analysis.ptc.fit import residual_se_widening

        m = len(fd) - settle
        w = residual_se_widening(m - 1)
        se = 100 * float(np.std(fd[settle:], ddof=1)) * math.sqrt(1 + 1 / m) * w / r.bright_signal_dn
        est = Estimate(est.value, se, "%", f"frame means; SE from the scatter of the {m} settled dark frame means "
                                           f"({m - 1} dof, x Student's t {w:.3g}) for the first dark frame less their mean")
    # (signed: a clamp recovering after the bright frames undershoots -- the first dark frame's residual
    # may be below the settled dark; one not resolved from 0 is a limit, never "ok")
    est = resolved(est, "image lag")
    return est, r.bright_signal_dn


def stage_lag_cycle(stage: dict):
    """The cycle inside a stage whose matched dark was grabbed after its flat (dark="after")."""
    if not stage.get("dark_after"):
        return None
    full = stage["views"]["full"]
    return lag_cycle(full["level"].get("frame_means") or [], (full.get("dark_level") or {}).get("frame_means") or [])


@register_scan_analysis("lag")
def lag(run, settle: int = LAG_SETTLE) -> dict:
    """Each bright->dark cycle: a flat stage followed by a dark stage, or a flat stage with
    its matched dark grabbed after it (``dark="after"``, e.g. every point of a 2-D bias
    sweep, which gives a lag map over the two axes)."""
    out = {}
    for k, a in enumerate(run.stages):
        if a["scene"] != "flat":
            continue
        if a.get("dark_after"):
            dark_name, cyc = f"{a['name']} (its matched dark, after)", stage_lag_cycle(a)
        elif k + 1 < len(run.stages) and run.stages[k + 1]["scene"] == "dark":
            b = run.stages[k + 1]
            dark_name = b["name"]
            cyc = lag_cycle(a["views"]["full"]["level"].get("frame_means") or [],
                            b["views"]["full"]["level"].get("frame_means") or [], settle)
        else:
            continue
        if cyc is None:
            continue
        est, bright = cyc
        out[a["name"]] = {"dark_stage": dark_name, "lag_pct": _e(est), "bright_signal_dn": bright,
                          "settings": {k_: v for k_, v in a["settings"].items() if k_ != "light"},
                          "coords": list(a.get("coords") or ())}
    if not out:
        return {"status": "not available", "note": f"needs flat stages followed by dark stacks of > {settle} frames "
                                                   "(a dark stage next, or dark=\"after\")"}
    return {"cycles": out}


@register_scan_analysis("defects")
def defects(run, overrides: dict | None = None) -> dict:
    """Defect classes from the per-pixel mean/variance maps of the dark stages (and the
    mid-level flat), thresholds from the scan's <defects>; ``overrides`` (name -> value,
    e.g. edited in the GUI) replace the scan's values for a re-classification of a
    finished run from its directory alone."""
    from ares.analysis.defects import DefectThresholds, PixelStats, classify_defects

    darks = [s for s in run.stages if s["scene"] == "dark" and s["settings"].get("reg:test_mode", 0) == 0]
    if not darks:
        return {"status": "not available", "note": "needs a dark stage"}
    if not run.arrays(darks[0]["index"]):
        return {"status": "not available", "note": "needs the run directory's results.h5 (per-pixel maps)"}

    def stats(st, key="mean"):
        a = run.arrays(st["index"])
        return PixelStats(a[key].astype(float), a["variance"].astype(float), st["frames"],
                          st["settings"].get("exposure"))

    th = DefectThresholds.from_attrs({**dict(run.scan.defects), **(overrides or {})},
                                     where=f"{run.scan.source}: <defects>")
    flat = mid_level_stage(run)
    flats = [stats(flat)] if flat is not None and flat["scene"] == "flat" else None
    k = _run_gain(run)
    res = classify_defects([stats(s) for s in darks], flats, gain_dn_per_e=k.value if k else None, thresholds=th,
                           rts_series=_rts_series(run, darks))
    return {"counts": {k_: (None if v is None else int(v)) for k_, v in res.counts.items()},
            "unavailable": dict(res.unavailable), "detection": dict(res.detection),
            "warnings": list(res.warnings), "notes": list(res.notes),
            "passed": bool(getattr(res, "passed", True)),
            "limits": res.limits, "dark_stages": [s["name"] for s in darks],
            "flat_stage": flat["name"] if flats else None, "criteria": _criteria(th, res), **_locations(res)}


def _rts_series(run, darks):
    """The RTS candidates' time series the runner kept from the dark stage the mask came
    from (``rts_series``/``rts_rows``/``rts_cols``), as a SeriesCollector; None without."""
    from ares.analysis.defects import SeriesCollector

    for s in darks:
        a = run.arrays(s["index"])
        if "rts_series" in a:
            return SeriesCollector.from_series(a["rts_rows"], a["rts_cols"], a["rts_series"])
    return None


def _criteria(th, res) -> dict[str, str]:
    """Per class: its rule with the scan's thresholds, plus what this run's frames can
    detect (or why the class is not available)."""
    out = {}
    for cls, rule in th.rules().items():
        if cls in res.unavailable:
            out[cls] = "not available: " + res.unavailable[cls]
        else:
            out[cls] = rule + (f"; {res.detection[cls]}" if cls in res.detection else "")
    return out


MAX_LOCATIONS = 5000  # per class, for the report's defect map (the counts are always complete)


def _locations(res) -> dict:
    """Where the defects are: per class up to MAX_LOCATIONS [x, y] pairs, bad lines by index."""
    loc: dict[str, list] = {}
    for r in res.defects:
        pts = loc.setdefault(str(r["cls"]), [])
        if len(pts) < MAX_LOCATIONS:
            pts.append([int(r["x"]), int(r["y"])])
    return {"shape": [int(res.shape[0]), int(res.shape[1])], "locations": loc,
            "bad_column_x": [int(c["x"]) for c in res.bad_columns], "bad_row_y": [int(r["y"]) for r in res.bad_rows]}


def check_defect_thresholds(scan) -> None:
    """Refuse unknown or malformed ``<defects>`` thresholds before any hardware is touched
    (the same parser the analysis uses, so what validates is what runs)."""
    if not scan.defects:
        return
    from ares.analysis.defects import DefectThresholds

    DefectThresholds.from_attrs(dict(scan.defects), where=f"{scan.source}: <defects>")
