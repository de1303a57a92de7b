"""The scan-level ``spectral_qe`` analysis (EMVA 1288 4.0 Linear, Section 9): QE(lambda)
from a monochromator sweep, with K from the photon-transfer stages of the same scan at the
same operation point (Section 9.2) -- ``ares.analysis.optics.spectral_qe`` does the arithmetic.

Which stages: the spectral points are the flat stages with a matched dark in a group
(``<sweep>``) whose stages set two or more wavelengths; every other flat stage with a
matched dark is a photon-transfer level for K (``ares.results.analyses.ptc_one``). Each point
needs the stage's ``spectral`` record (the runner's: wavelength read back, photodiode
readings lit and dark). Registered by importing ``ares.results``."""

from __future__ import annotations

import math

from ares.analysis.stats.estimate import Estimate
from ares.analysis.optics.spectral_qe import spectral_groups
from ares.results.registry import register_scan_analysis


def _frame_se(level: dict) -> float:
    """SE (DN) of a stack's mean from the scatter of its frame means (the frame-global and
    row/column temporal terms move every frame's mean; the pixel noise is inside it)."""
    fm = level.get("frame_means") or []
    if len(fm) < 2:
        return math.nan
    m = sum(fm) / len(fm)
    return math.sqrt(sum((x - m) ** 2 for x in fm) / (len(fm) - 1) / len(fm))


def _point(st: dict):
    from ares.analysis.optics.spectral_qe import SpectralPoint, mean_se

    full, sp = st["views"]["full"], st["spectral"]
    lv, dk = full["level"], full["dark_level"]
    light, light_se = mean_se(sp["pd_light"])
    dark, dark_se = mean_se(sp["pd_dark"]) if sp.get("pd_dark") else (0.0, 0.0)
    nm = sp["wavelength_nm"] if sp.get("wavelength_nm") is not None else st["settings"]["wavelength"]
    return SpectralPoint(nm, sp["bandwidth_nm"] if sp.get("bandwidth_nm") is not None else math.nan,
                         st["settings"].get("exposure", math.nan), lv["mean_dn"], _frame_se(lv), dk["mean_dn"],
                         _frame_se(dk), math.sqrt(max(dk["var_dn2"] or 0.0, 0.0)), lv["frac_at_max"],
                         lv["var_dn2"] if lv["var_dn2"] is not None else math.nan, light, light_se, dark, dark_se)


def _gain(run, stages: list[dict]) -> tuple[Estimate, str]:
    """K from the photon-transfer levels at the spectral points' analog gain, as the ``ptc``
    analysis computes it (``ares.results.analyses``), and where it came from."""
    from ares.results.analyses import _ptc_groups, ptc_one

    gains = {st["settings"].get("analog_gain", 1.0) for st in stages}
    if len(gains) != 1:
        return Estimate.na("the spectral stages use more than one analog gain", "DN/e-"), ""
    gain = gains.pop()
    ptc = _ptc_groups(run).get(gain, [])
    if len(ptc) < 2:
        return Estimate.na("needs a photon-transfer sweep (2 or more flat levels with a matched dark) at the "
                           "spectral points' operation point", "DN/e-"), ""
    k = ptc_one(run, ptc, gain).get("gain_dn_per_e")
    where = f"photon transfer of {len(ptc)} levels ({', '.join(sorted({s['group'] for s in ptc}))})"
    return (Estimate.from_dict(k) if k else Estimate.na("photon transfer gave no K", "DN/e-")), where


def point_key(nm: float) -> str:
    """``550nm``; ``402_5nm`` (no dot: a key of a dotted path); a wavelength measured in two
    sweeps gets the second sweep's name appended (``550nm_long``)."""
    return f"{nm:g}nm".replace(".", "_")


@register_scan_analysis("spectral_qe")
def spectral_qe(run) -> dict:
    from ares.analysis.optics.spectral_qe import qe_point

    pd = run.system.photodiode
    if pd is None:
        return {"status": "not available", "note": "the system declares no <photodiode> (reference photodiode)"}
    groups = spectral_groups(run.stages)
    stages = [st for st in run.stages if st["group"] in groups and st["scene"] == "flat"
              and "dark_level" in st["views"]["full"] and (st.get("spectral") or {}).get("pd_light")]
    if not stages:
        return {"status": "not available", "note": "no wavelength sweep of flat stages with a matched dark and "
                                                   "photodiode readings"}
    K, where = _gain(run, stages)
    t = pd.table
    table = (t.wavelength_nm, t.responsivity_a_per_w, t.u_a_per_w)
    pitch = run.system.sensor.pixel_pitch_um
    points = {}
    for st in sorted(stages, key=lambda s: s["settings"]["wavelength"]):
        p = _point(st)
        if not pitch:
            r = {"qe": Estimate.na("the system's <array pixel_pitch_um> is not given (the pixel area of Eq. 3)", "%")}
        else:
            r = qe_point(p, K, table, pd.area_mm2 * 1e-6, (pitch * 1e-6) ** 2, pd.reading)
        out = {"stage": st["name"], "wavelength_nm": p.wavelength_nm,
               "bandwidth_nm": None if math.isnan(p.bandwidth_nm) else p.bandwidth_nm}
        out.update({k: (v.to_dict() if isinstance(v, Estimate) else v) for k, v in r.items()})
        key = point_key(p.wavelength_nm)
        if key in points:  # the same wavelength in another sweep (another exposure, Section 9.2)
            key = f"{key}_{st['group']}" if f"{key}_{st['group']}" not in points else f"{key}_{st['index']}"
        points[key] = out
    bw = [p["bandwidth_nm"] for p in points.values() if p["bandwidth_nm"] is not None]
    res = {"gain_dn_per_e": K.to_dict(), "gain_source": where, "points": points,
           "calibration": {"file": pd.calibration, "range_nm": [t.wavelength_nm[0], t.wavelength_nm[-1]],
                           "reading": pd.reading, "area_mm2": pd.area_mm2, **t.provenance()},
           "pixel_pitch_um": pitch}
    if bw and max(bw) > 10:  # Section 9.2: FWHM below 10 nm, up to 50 nm allowed when reported
        res["warnings"] = [f"bandwidth (FWHM) up to {max(bw):g} nm: above the 10 nm EMVA 1288 4.0 asks for "
                           "(Section 9.2; allowed up to 50 nm, reported)"]
    return res
