"""Scan-level ``emva4`` analysis: the EMVA 1288 Release 4.0 Linear parameter set (every
Table 2 figure) and the Release 4.0 General values from what a scan measured -- the same
evaluation ``ares emva`` runs on a recorded descriptor set (``ares.analysis.emva.sheet``).

What the scan must hold (``scans/emva_4.xml`` is the example):

- photon-transfer steps: flat stages with a matched dark (Linear Section 6.5: two images
  per step, >= 50 steps from dark to saturation), outside the groups below; the photons
  per pixel are the stage's light level x exposure;
- the averaged stacks of Section 8: a flat stage in the group ``spatial`` (~50 % of
  saturation, L >= 100 frames) and its dark -- its matched dark or a dark stage in the group
  ``spatial_dark`` at the same exposure;
- dark current (Section 7.1): dark stages in the group ``dark_current`` at >= 6 exposure
  times (else the photon-transfer darks are used); at several temperatures, one series per
  temperature (Section 7.2).

Per-step spatial variances (Sections 4.2/4.3) come from each stage's averaged image in
``results.h5`` (``mean``, ``dark_mean``); the stacks' averaged images likewise.
"""

from __future__ import annotations

import math

import numpy as np

from ares.results.emva1288 import SPATIAL_GROUP, release3_variance
from ares.results.registry import register_scan_analysis

DARK_CURRENT_GROUP = "dark_current"
_EXCLUDED = (SPATIAL_GROUP, SPATIAL_GROUP + "_dark", DARK_CURRENT_GROUP)


def _line(comp: dict | None, level: dict) -> tuple[float | None, float | None, float, float]:
    """(row-mean and column-mean temporal variances, Rt, Ct) from a stage's ANOVA components
    (``Rt + Pt/N``, ``Ct + Pt/M``); None when the stage has none."""
    def val(k):
        v = (comp or {}).get(k) or {}
        return v.get("value")
    pt, rt, ct = val("Pt"), val("Rt"), val("Ct")
    if None in (pt, rt, ct):
        return None, None, 0.0, 0.0
    m = level.get("rows") or 0
    n = level["n_pixels"] // m if m else 0
    if not m or not n:
        return None, None, 0.0, 0.0
    return rt + pt / n, ct + pt / m, rt, ct


def _stats(level: dict, comp: dict | None = None, shape=None):
    """The stage level as ``LevelStats`` (``analyses._levelstats``), with the sampling of its
    row/column temporal parts (from the stage's ANOVA) in the variance's SE."""
    import dataclasses

    from ares.results.analyses import _levelstats

    st = _levelstats(level)
    if comp and shape:
        _, _, rt, ct = _line(comp, {**level, "rows": shape[0]})
        f = max(level["n_frames"] - 1, 1)
        st = dataclasses.replace(st, line_var2=2 * max(rt, 0) ** 2 / (shape[0] * f) + 2 * max(ct, 0) ** 2
                                 / (shape[1] * f))
    return st


def _split(img, level: dict, comp: dict | None):
    from ares.analysis.spatial.nonuniformity import split

    var = level.get("var_dn2")
    var = math.nan if var is None else float(var)
    L = int(level["n_frames"])
    rv, cv, _, _ = _line(comp, {**level, "rows": img.shape[0]})
    try:
        return split(img, var, L, "4.0", rv, cv)
    except ValueError:  # smaller than the high-pass
        return split(img, var, L, "none", rv, cv)


def _meta(run) -> dict:
    m = run.meta or {}
    sim = getattr(getattr(run, "scan", None) and run.system, "simulator", None)
    steps = [s for s in run.stages if s["scene"] == "flat" and s["group"] not in _EXCLUDED]
    exps = sorted({s["settings"].get("exposure") for s in steps if s["settings"].get("exposure") is not None})
    lights = sorted({s["settings"].get("light") for s in steps if s["settings"].get("light") is not None})
    first = steps[0]["settings"] if steps else {}
    temps = {s["settings"].get("temperature") for s in run.stages} - {None}
    started = str(m.get("started") or "")
    meta = {"source": f"run {run.dir.resolve().name if run.dir else ''} ({m.get('scan_name', '')})",
            "date": started[:10] or None, "vendor": "ARES simulator" if sim is not None else None,
            "model": m.get("system_name"), "serial": f"seed {m.get('seed')}" if sim is not None else None,
            "type_of_data": "single",
            "exposure_control": "exposure time (method I)" if len(exps) > 1 else "irradiance (method II)",
            "exposure_time": (f"{1e3 * exps[0]:.3g} - {1e3 * exps[-1]:.3g} ms" if len(exps) > 1 else
                              f"{1e3 * exps[0]:.3g} ms" if exps else None),
            "gain_black_level": ", ".join(x for x in (
                f"analog gain {first['analog_gain']:g}x" if first.get("analog_gain") is not None else "",
                f"black level {first['black_level']:g} DN" if first.get("black_level") is not None else "") if x)
            or None,
            "env_temperature": ", ".join(f"{t:g} °C" for t in sorted(temps)) or None,
            "irradiance": f"{lights[0]:g} photons/pixel/s" if len(lights) == 1 else None,
            "footer": f"ARES · scan {m.get('scan_name', '')} · system {m.get('system_name', '')}"}
    if sim is not None:
        from ares.sim import SensorParams

        p = SensorParams(**{k: v for k, v in sim.params.items() if k in SensorParams.__dataclass_fields__})
        meta["pixel_pitch_um"] = p.pixel_pitch_um
        meta["data_mode"] = f"Mono {p.adc_bits}"
    return meta


def _stack(img, level: dict, comp: dict | None, photons: float, exposure: float):
    from ares.analysis.emva.sheet import StackImage
    from ares.analysis.ptc.levels import LineTemporal

    rv, cv, _, _ = _line(comp, {**level, "rows": img.shape[0]})
    line = LineTemporal(float(level["var_dn2"]), rv, cv) if rv is not None else None
    return StackImage(np.asarray(img, np.float64), release3_variance(level), int(level["n_frames"]), photons,
                      exposure, line)


def build_input(run):
    """``EmvaInput`` from a run's stage results and averaged images; None (and the reason)
    when the scan has fewer than 3 photon-transfer steps."""
    from ares.analysis.emva.sheet import EmvaInput

    steps = [s for s in run.stages if s["scene"] == "flat" and "dark_level" in s["views"]["full"]
             and s["group"] not in _EXCLUDED]
    gains = sorted({s["settings"].get("analog_gain", 1.0) for s in steps})
    gain = 1.0 if 1.0 in gains else (gains[0] if gains else 1.0)
    steps = [s for s in steps if s["settings"].get("analog_gain", 1.0) == gain]
    if len(steps) < 3:
        return None, f"needs >= 3 flat stages with a matched dark (photon-transfer steps), has {len(steps)}"
    if any(s["settings"].get("exposure") is None or s["settings"].get("light") is None for s in steps):
        return None, "needs exposure and light settings on every photon-transfer stage"
    bright, dark, splits, diffs = [], [], [], []
    for s in steps:
        full = s["views"]["full"]
        arr = run.arrays(s["index"])
        shape = arr["mean"].shape if "mean" in arr else None
        bright.append(_stats(full["level"], full.get("flat_anova"), shape))
        dark.append(_stats(full["dark_level"], full.get("components"), shape))
        if "mean" in arr and "dark_mean" in arr:
            splits.append((_split(arr["mean"], full["level"], full.get("flat_anova")),
                           _split(arr["dark_mean"], full["dark_level"], full.get("components"))))
        fm = full["level"].get("frame_means") or []
        diffs.append(fm[0] - fm[1] if len(fm) >= 2 else math.nan)
    texp = np.array([s["settings"]["exposure"] for s in steps], float)
    photons = np.array([s["settings"]["light"] for s in steps], float) * texp
    stack_b = stack_d = None
    sp = [s for s in run.stages if s["scene"] == "flat" and s["group"] == SPATIAL_GROUP]
    if sp:
        st = sp[0]
        exp = float(st["settings"].get("exposure") or math.nan)
        full = st["views"]["full"]
        arr = run.arrays(st["index"])
        if "mean" in arr:  # the averaged images are in results.h5 (none for a run without a directory)
            stack_b = _stack(arr["mean"], full["level"], full.get("flat_anova"),
                             float(st["settings"].get("light") or 0) * exp, exp)
        if "dark_mean" in arr:
            stack_d = _stack(arr["dark_mean"], full["dark_level"], full.get("components"), 0.0, exp)
        else:
            ds = [s for s in run.stages if s["scene"] == "dark" and s["group"] == SPATIAL_GROUP + "_dark"
                  and s["settings"].get("exposure") == st["settings"].get("exposure")]
            darr = run.arrays(ds[0]["index"]) if ds else {}
            if "mean" in darr:
                f = ds[0]["views"]["full"]
                stack_d = _stack(darr["mean"], f["level"], f.get("components"), 0.0, exp)
    series = _dark_series(run)
    meta = _meta(run)
    pitch = meta.pop("pixel_pitch_um", None)
    if pitch:  # the datasheet's "Pixel size" is the one the .area figures were divided by
        meta["pixel_size"] = f"{pitch:g} x {pitch:g} µm"
    inp = EmvaInput(photons, texp, bright, dark, splits if len(splits) == len(steps) else None, np.array(diffs),
                    stack_d if stack_b is not None else None, stack_b if stack_d is not None else None,
                    dark_series=series.pop(None, None) or (next(iter(series.values())) if len(series) == 1 else None),
                    temperatures=[(T, *v) for T, v in sorted(series.items())] if len(series) >= 2 else None,
                    pixel_area_um2=pitch * pitch if pitch else None, meta=meta)
    if sp and (stack_b is None or stack_d is None):
        inp.notes.append("the averaged images of the Section 8 stacks are not stored (a run without a run "
                         "directory, or its results.h5 lacks them): no DSNU1288/PRNU1288")
    if len(splits) != len(steps):
        inp.notes.append("the per-step averaged images are not stored: no spatial variances per exposure step")
    return inp, ""


def _dark_series(run) -> dict:
    """Dark-current stages by temperature (None: no temperature setting): (t, mean, var)."""
    by: dict = {}
    for s in run.stages:
        if s["scene"] != "dark" or s["group"] != DARK_CURRENT_GROUP:
            continue
        lv = s["views"]["full"]["level"]
        T = s["settings"].get("temperature")
        by.setdefault(T, []).append((float(s["settings"]["exposure"]), lv["mean_dn"], lv["var_dn2"]))
    out = {}
    for T, rows in by.items():
        a = np.array(sorted(rows), float)
        out[T] = (a[:, 0], a[:, 1], a[:, 2])
    return out


def evaluate(run):
    """(sheet, general, reason): the Release 4.0 Linear sheet and the General result."""
    from ares.analysis.emva.sheet import evaluate_linear
    from ares.analysis.emva.general import general_from_input

    inp, why = build_input(run)
    if inp is None:
        return None, None, why
    sheet = evaluate_linear(inp)
    general = general_from_input(inp, sheet.photon_transfer)  # the whole General Table 2
    return sheet, general, ""


@register_scan_analysis("emva4")
def emva4(run) -> dict:
    sheet, general, why = evaluate(run)
    if sheet is None:
        return {"status": "not available", "note": why}
    out = sheet.to_json()
    out["general"] = {"release": "EMVA 1288 Release 4.0 General", "values": general.to_json(),
                      "notes": general.notes}
    bench = (run.meta or {}).get("bench") or {}
    if bench.get("attribution"):
        out["attribution"] = bench["attribution"]
    return out
