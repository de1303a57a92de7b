"""Scan-level ``emva1288`` analysis: the EMVA 1288 (Release 3.0) parameters from a scan's
stage results, with the standard's own definitions -- the same numbers ``ares emva``
prints for a descriptor file, but from whatever the Runner measured (live or replayed).

Definitions (as ``ares.analysis.emva.release3``, not ARES's ``ptc``):

- temporal variance **without** the frame-offset correction: ARES's stage ``var_dn2``
  removes the frame-global offset (Release 4.0 / ARES), so the Release 3.0 variance is
  rebuilt exactly as ``var_dn2 (P - 1) / P + sum_f (m_f - m)^2 / (F - 1)`` from the stage's
  frame means (P pixels; ``var_dn2`` has (P - 1)(F - 1) degrees of freedom);
- K: origin fit of (s2_y - s2_y.dark) vs (mu_y - mu_y.dark) up to 70 % of the
  maximum-variance (saturation) level; sigma_y.dark: intercept of s2_y.dark vs exposure;
- photons per pixel: the stage's light level x exposure (photons/pixel/s x s);
- DSNU1288/PRNU1288 from the flat stage named ``spatial`` (a long stack) and its dark:
  its matched dark, or a dark stage named ``spatial_dark`` at the same exposure.

Temporal levels: every flat stage with a matched dark outside the ``spatial`` group, at
analog gain 1 (or the first gain), sorted by exposure then light.
"""

from __future__ import annotations

import numpy as np

from ares.results.registry import register_scan_analysis

SPATIAL_GROUP = "spatial"


def release3_variance(level: dict) -> float:
    """EMVA 1288 Release 3.0 temporal variance (no frame-offset correction) of a stage level."""
    fm = np.asarray(level.get("frame_means") or [], dtype=float)
    var = float(level["var_dn2"])
    if fm.size >= 2:
        p = int(level["n_pixels"])
        var = var * (p - 1) / p + float(np.sum((fm - fm.mean()) ** 2)) / (fm.size - 1)
    return var


def _spatial(level: dict):
    from ares.analysis.ptc.levels import SpatialStats

    F = int(level["n_frames"])
    measured = float(level["spatial_var_dn2"]) + float(level["var_dn2"]) / F  # var of the mean image
    return SpatialStats(float(level["mean_dn"]), measured, release3_variance(level), F, int(level["n_pixels"]))


@register_scan_analysis("emva1288")
def emva1288(run) -> dict:
    from ares.analysis.emva.release3 import TemporalData, emva1288_results

    temporal = [s for s in run.stages if s["scene"] == "flat" and "dark_level" in s["views"]["full"]
                and s["group"] != SPATIAL_GROUP]
    gains = sorted({s["settings"].get("analog_gain", 1.0) for s in temporal})
    gain = 1.0 if 1.0 in gains else (gains[0] if gains else 1.0)
    temporal = [s for s in temporal if s["settings"].get("analog_gain", 1.0) == gain]
    if len(temporal) < 3:
        return {"status": "not available", "note": "needs at least 3 flat stages with a matched dark"}
    if any(s["settings"].get("exposure") is None or s["settings"].get("light") is None for s in temporal):
        return {"status": "not available", "note": "needs exposure and light settings on every flat stage"}
    temporal.sort(key=lambda s: (s["settings"]["exposure"], s["settings"]["light"]))
    lv = [s["views"]["full"]["level"] for s in temporal]
    dk = [s["views"]["full"]["dark_level"] for s in temporal]
    texp = np.array([s["settings"]["exposure"] for s in temporal], dtype=float)
    td = TemporalData(texp, np.array([s["settings"]["light"] for s in temporal], dtype=float) * texp,
                      np.array([x["mean_dn"] for x in lv]), np.array([release3_variance(x) for x in lv]),
                      np.array([x["mean_dn"] for x in dk]), np.array([release3_variance(x) for x in dk]),
                      int(lv[0]["n_pixels"]))
    sb = sd = None
    spatial = [s for s in run.stages if s["scene"] == "flat" and s["group"] == SPATIAL_GROUP]
    if spatial:
        full = spatial[0]["views"]["full"]
        exp = spatial[0]["settings"].get("exposure")
        darks = [s for s in run.stages if s["scene"] == "dark" and s["group"] == SPATIAL_GROUP + "_dark"
                 and s["settings"].get("exposure") == exp]
        dark = full.get("dark_level") or (darks[0]["views"]["full"]["level"] if darks else None)
        if dark is not None:
            sb, sd = _spatial(full["level"]), _spatial(dark)
    r = emva1288_results(td, sb, sd)
    out = {k: v.to_dict() for k, v in r.values.items()}
    out.update({
        "definitions": "EMVA 1288 Release 3.0 (variance without frame-offset correction, origin fit)",
        "index_u_ysat": r.index_u_ysat, "saturation_stage": temporal[r.index_u_ysat]["name"],
        "levels": len(temporal), "analog_gain": gain,
        "spatial_stage": spatial[0]["name"] if spatial else None,
        "photons_from": "light x exposure",
    })
    bench = (run.meta or {}).get("bench") or {}
    if bench.get("attribution"):
        out["attribution"] = bench["attribution"]
    return out
