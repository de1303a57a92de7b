"""Report tables of dark series (dark current against exposure and temperature) and of the ADC (INL/DNL per channel)."""

from __future__ import annotations

import math
import numpy as np
from ares.analysis.stats.estimate import Estimate


def dark_series(run) -> dict[float | None, dict[str, np.ndarray]]:
    """Dark stages grouped by temperature (None when not set): exposure, mean, temporal
    and spatial variance, sorted by exposure."""
    from ares.results.dark_drift import frame_times

    out: dict = {}
    for st in run.stages:
        if st.get("scene") != "dark" or "exposure" not in st["settings"]:
            continue
        lv = st["views"]["full"]["level"]
        t = st["settings"].get("temperature")
        out.setdefault(t, []).append((float(st["settings"]["exposure"]), lv["mean_dn"], _nan(lv.get("var_dn2")),
                                      _nan(lv.get("spatial_var_dn2")), lv.get("frame_means"), frame_times(st, run)))
    res = {}
    for t, rows in out.items():
        rows = sorted(rows, key=lambda r: r[:4])
        a = np.array([r[:4] for r in rows], float)
        res[t] = {"exposure_s": a[:, 0], "mean_dn": a[:, 1], "var_dn2": a[:, 2], "spatial_var_dn2": a[:, 3],
                  "frame_means": [r[4] for r in rows], "frame_times": [r[5] for r in rows]}
    return res


def dark_current_figures(run, gain: Estimate | None) -> dict:
    """Dark current per temperature from the dark stages with ``ares.analysis.ptc.dark_current``
    (the runner's definition: slope of the dark mean vs exposure, >= 6 exposures), in DN/s
    and -- with a gain -- e-/s. Used when the run has no dark_current analysis result."""
    from ares.analysis.ptc.dark_current import MIN_EXPOSURES, dark_current
    from ares.results.dark_drift import drift_verdict

    kf = {}
    for t, s in dark_series(run).items():
        if np.unique(s["exposure_s"]).size < MIN_EXPOSURES:
            continue
        dc = dark_current(s["exposure_s"], s["mean_dn"], gain if gain is not None else math.nan, s["var_dn2"],
                          frame_means=s["frame_means"], frame_times=s["frame_times"])
        at = "" if t is None else f" at {t:g} C"
        key = "dark_current" + ("" if t is None else f"@{t:g}C")
        kf[key + "_dn_per_s"] = drift_verdict(_entry("dark current" + at, dc.rate_dn_per_s,
                                                     "computed by the report from dark stages"), dc.drift)
        if dc.rate_e_per_s.available:
            kf[key + "_e_per_s"] = drift_verdict(_entry("dark current" + at, dc.rate_e_per_s,
                                                        "computed by the report from dark stages"), dc.drift)
    return kf


ADC_COLUMNS = ("channel", "code", "dnl_lsb", "dnl_se_lsb", "transition", "inl_lsb", "inl_se_lsb")


def adc_curves(run, d: dict) -> dict:
    """Channel -> ``InlDnl`` of the ``adc_linearity`` analysis ``d``: the code-density test on
    its ramp stages' code histograms in results.h5, as the runner computed its extremes (with
    the scatter SEs of their sub-histograms, or the counting SEs of a run that has none)."""
    from ares.results.adc import ramp_curves

    chans = d.get("channels") or {}
    return {ch: r for ch, r in ramp_curves(run, d.get("stages") or []).items() if ch in chans}


def adc_channels_now(d: dict, curves: dict) -> tuple[dict, list[str]]:
    """The ``adc_linearity`` analysis ``d``'s channels for a report table, and the channels
    judged again: a run written before the sub-histograms recorded counting-SE extremes "ok"
    with SEs far above their values; those are shown as the analysis judges them now (its
    curves ``curves``, ``adc_curves``: limits, the counting SE said so)."""
    chans = dict(d.get("channels") or {})
    again = [ch for ch, r in curves.items() if not r.scatter and ch in chans]
    for ch in again:
        chans[ch] = {**chans[ch], **{f"{k}_lsb": e.to_dict() for k, e in curves[ch].extremes().items()}}
    return chans, again


def adc_se_notes(run) -> dict[str, str]:
    """Channel -> how the SEs of its INL/DNL curves were made (``InlDnl.se_note``)."""
    d = run.analyses.get("adc_linearity")
    if not isinstance(d, dict) or not d.get("channels"):
        return {}
    return {ch: r.se_note() for ch, r in adc_curves(run, d).items()}


def adc_rows(run) -> list[dict]:
    """The INL/DNL curves per channel with their SEs (adc_inl_dnl.csv; ``InlDnl.se_note``)."""
    d = run.analyses.get("adc_linearity")
    if not isinstance(d, dict) or not d.get("channels"):
        return []
    rows = []
    for ch, r in adc_curves(run, d).items():
        dse, ise = r.dnl_se(), r.inl_se()
        for k in range(r.first, r.last):
            j = k + 1  # transition k+1 lies between codes k and k+1
            rows.append({"channel": ch, "code": k, "dnl_lsb": float(r.dnl[k]), "dnl_se_lsb": float(dse[k]),
                         "transition": j, "inl_lsb": float(r.inl[j - 1]), "inl_se_lsb": float(ise[j - 1])})
    return rows


def _nan(x) -> float:
    return math.nan if x is None else float(x)


def _entry(label: str, e: Estimate, source: str) -> dict:
    d = {"label": label, "value": e.value if e.available else None,
         "se": e.se if math.isfinite(e.se) else None, "unit": e.unit, "note": e.note, "source": source,
         "verdict": e.verdict}
    if e.is_exact:  # SE 0: declared, not measured -- said beside the value on every surface
        d["exact"] = e.to_dict()["exact"]
    return d
