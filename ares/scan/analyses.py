"""Built-in scan-level analyses, registered with ``ares.scan.results.register_scan_analysis``.

Each takes a ``RunRecord`` (scan + stage results) and returns a JSON-able dict of
``Estimate.to_dict()`` values. They adapt stage results to the characterization
module (``ares.analysis.ptc`` ...); the numbers are computed there.
"""

from __future__ import annotations

import math

from ares.analysis.estimate import Estimate
from ares.scan.results import register_scan_analysis


def _levelstats(level: dict):
    from ares.analysis.levels import LevelStats

    nan = math.nan
    return LevelStats(level["mean_dn"], level["var_dn2"] if level["var_dn2"] is not None else nan,
                      level["n_pixels"], level["n_frames"], level["frac_at_max"], level["frac_at_min"],
                      level["spatial_var_dn2"] if level.get("spatial_var_dn2") is not None else nan)


def _e(x: Estimate) -> dict:
    return x.to_dict()


def _ptc_groups(run) -> dict:
    """Flat stages with a matched dark, grouped by analog gain (one PTC per gain)."""
    groups: dict = {}
    for st in run.stages:
        full = st["views"]["full"]
        if st["scene"] != "flat" or "dark_level" not in full:
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


def ptc_one(run, stages: list, analog_gain: float) -> dict:
    from ares.analysis.ptc import analyze_ptc

    bright = [_levelstats(s["views"]["full"]["level"]) for s in stages]
    dark = [_levelstats(s["views"]["full"]["dark_level"]) for s in stages]
    exp = [s["settings"].get("exposure", math.nan) for s in stages]
    light = [s["settings"].get("light") for s in stages]
    photons = [l_ * e for l_, e in zip(light, exp)] if all(v is not None for v in light) else None
    if photons is not None and len(set(photons)) < 2:
        photons = None
    r = analyze_ptc(bright, dark, exposure_s=exp if all(math.isfinite(e) for e in exp) else None,
                    photons=photons, adc_lsb_uv=_adc_lsb_uv(run.system), analog_gain=analog_gain)
    return {
        "analog_gain": analog_gain,
        "levels": len(stages),
        "gain_dn_per_e": _e(r.gain_dn_per_e), "gain_e_per_dn": _e(r.gain_e_per_dn),
        "conversion_gain_uv_per_e": _e(r.conversion_gain_uv_per_e),
        "read_noise_dn": _e(r.read_noise_dn), "read_noise_e": _e(r.read_noise_e),
        "read_noise_is_upper_limit": r.read_noise_is_upper_limit,
        "full_well_e": _e(r.full_well_e["max_variance"]),
        "full_well_definitions": {k: _e(v) for k, v in r.full_well_e.items()},
        "dynamic_range_db": _e(r.dynamic_range_db), "qe": _e(r.qe),
        "linearity_error_pct": _e(r.linearity_error_pct),
        "saturation_stage": stages[r.saturation_index]["name"] if r.saturation_index >= 0 else None,
        "level_status": [{"stage": stages[lv.index]["name"], "status": lv.status, "reason": lv.reason}
                         for lv in r.levels],
    }


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
    return {"stage": st["name"], "settings": st["settings"], "components": full["components"]}
