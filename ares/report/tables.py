"""Key-figure, PTC-level and component tables of a run directory.

Numbers come from the run directory: scan-level results from ``scan_results.json``
when the run finished; the photon-transfer curve itself (per-level signal, variance,
SNR, noise model, which the scan results summarise) is recomputed here from the
per-stage level statistics with ``ares.analysis.ptc.photon_transfer.analyze_ptc`` -- the same inputs
the runner's PTC analysis uses. A partial run has no ``scan_results.json``: then every
key figure comes from that recomputation and says so in its note.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


from ares.analysis.stats.estimate import (GAIN_SPREADS, Estimate, component_display, component_text,  # noqa: F401
                                    format_value)  # (component_* re-exported for the report pages)
from ares.analysis.ptc.levels import LevelStats
from ares import labels
from ares.analysis.stats.physical import snr_db
from ares.analysis.ptc.photon_transfer import PtcResult, analyze_ptc
from ares.results.registry import ptc_level_keys
from ares.results.analyses import signal_se  # one definition: the input the runner's PTC analysis gives
from ares.report.series_tables import dark_current_figures
from ares.report.series_tables import _entry, _nan
from ares.report.page_tables import analysis_label

# the 13 components (DESIGN.md / seed 001) in model order, then the extras ARES reports
COMPONENTS = ("o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "G", "Cg", "Rg", "Pg", "q", "delta")
EXTRA_COMPONENTS = ("frame_global", "signal")
COMPONENT_LABELS = labels.COMPONENTS
# "components" holds every pixel; "components_masked" (the figures the terminal and the key
# figures state where the run masked its defect pixels) leaves the defect pixels out
COMPONENT_PARTS = ("components", "components_masked", "dark_components", "flat_anova")
PART_NOTES = {"components": "all pixels", "components_masked": "defect pixels excluded"}


component_label = labels.component_label


FULL_WELL_LABELS = {
    "saturation_capacity": labels.figure_name("saturation_capacity_e"),
    "bracket": "full well, saturation bracket centre",
    "max_variance": "full well, max variance (EMVA 1288 3.0)",
    "max_code": "full well, max code (EMVA 1288 4.0)",
    "plateau": "full well, saturated plateau",
    "linearity_1pct": "full well, 1 % linearity limit",
}


def levelstats(level: dict) -> LevelStats:
    return LevelStats(float(level["mean_dn"]), _nan(level.get("var_dn2")), int(level["n_pixels"]),
                      int(level["n_frames"]), float(level.get("frac_at_max") or 0.0),
                      float(level.get("frac_at_min") or 0.0), _nan(level.get("spatial_var_dn2")))


def est(d) -> Estimate:
    """An ``Estimate`` from its JSON dict (None -> not available)."""
    if not isinstance(d, dict):
        return Estimate.na("not in the run directory")
    return Estimate.from_dict(d)  # (with its verdict: an upper or lower limit stays one)


# ------------------------------------------------------------------ PTC groups

@dataclass
class PtcGroup:
    analog_gain: float
    stages: list[dict]
    result: PtcResult | None  # None: fewer than 2 levels
    stored: dict  # the runner's scan_results entry for this gain ({} if none)
    exposure_s: list[float]
    light: list[float | None]
    photons: list[float] | None

    @property
    def is_curve(self) -> bool:
        """A photon-transfer curve needs >= 3 distinct illumination levels (photons, else
        exposures, else signals > 2 % apart): a register sweep at one light level is not one."""
        if self.photons is not None:
            xs = self.photons
        elif all(math.isfinite(e) for e in self.exposure_s) and len(set(self.exposure_s)) > 1:
            xs = self.exposure_s
        else:
            xs = [s["views"]["full"]["level"]["mean_dn"] - s["views"]["full"]["dark_level"]["mean_dn"]
                  for s in self.stages]
        xs = sorted(x for x in xs if x is not None and math.isfinite(x) and x > 0)
        distinct = [x for i, x in enumerate(xs) if i == 0 or x > 1.02 * xs[i - 1]]
        return len(distinct) >= 3

    def mismatch(self) -> str:
        """A sentence when the recomputed curve's K differs from the runner's (else "")."""
        k = est(self.stored.get("gain_dn_per_e"))
        if self.result is None or not k.available or not self.result.gain_dn_per_e.available:
            return ""
        r = self.result.gain_dn_per_e.value
        if abs(r - k.value) <= 1e-6 * abs(k.value):
            return ""
        return (f"note: the curves are recomputed from the stage results (K = {r:.5g} DN/e-); the key figures are "
                f"the run's own scan_results.json (K = {k.value:.5g} DN/e-)")

    def status(self, i: int) -> tuple[str, str]:
        """(status, reason) of level ``i``: the runner's if it recorded one, else ours."""
        for row in self.stored.get("level_status") or []:
            if row.get("stage") == self.stages[i]["name"]:
                return row.get("status", ""), row.get("reason", "")
        if self.result is None:
            return "", "fewer than 2 levels: no PTC"
        lv = self.result.levels[i]
        return lv.status, lv.reason


def _adc_lsb_uv(run, stored: dict) -> float | None:
    cg, k = est(stored.get("conversion_gain_uv_per_e")), est(stored.get("gain_dn_per_e"))
    if cg.available and k.available and k.value:
        return cg.value / k.value * float(stored.get("analog_gain") or 1.0)
    try:  # partial run: the system XML's simulator LSB
        from ares.protocol import load_system

        system = load_system(run.dir / run.meta["system_file"])
        sim = system.simulator
        if sim is None:
            return None
        if "adc_lsb_uv" in sim.params:
            return float(sim.params["adc_lsb_uv"])
        from ares.sim import SensorParams

        return float(SensorParams().adc_lsb_uv)
    except Exception:  # noqa: BLE001 -- best effort; conversion gain is then n/a
        return None


def _analyze(bright, dark, **kw) -> PtcResult:
    import inspect

    if "signal_se" not in inspect.signature(analyze_ptc).parameters:
        kw.pop("signal_se", None)
    return analyze_ptc(bright, dark, **kw)


def _stored_ptc(run, gain: float) -> dict:
    ptc = run.analyses.get("ptc") or {}
    for r in (ptc.get("by_analog_gain") or {}).values():
        if r.get("analog_gain") == gain:
            return r
    return ptc if ptc.get("analog_gain", gain) == gain and "gain_dn_per_e" in ptc else {}


def ptc_groups(run) -> list[PtcGroup]:
    """Flat stages with a matched dark, one group per analog gain (as the runner groups)."""
    from ares.analysis.optics.spectral_qe import spectral_groups

    groups: dict[float, list[dict]] = {}
    spectral = spectral_groups(run.stages)  # a wavelength sweep's stages are not photon-transfer levels
    for st in run.stages:
        full = st["views"]["full"]
        if st.get("scene") == "flat" and "dark_level" in full and st.get("group") not in spectral:
            groups.setdefault(float(st["settings"].get("analog_gain", 1.0)), []).append(st)
    out = []
    for g, sts in groups.items():
        stored = _stored_ptc(run, g)
        exp = [_nan(s["settings"].get("exposure")) for s in sts]
        light = [s["settings"].get("light") for s in sts]
        photons = [l_ * e for l_, e in zip(light, exp)] if all(v is not None for v in light) else None
        if photons is not None and len(set(photons)) < 2:
            photons = None
        res = None
        if len(sts) >= 2:
            lv, dk = ptc_level_keys(sts)
            bright = [levelstats(s["views"]["full"][lv]) for s in sts]
            dark = [levelstats(s["views"]["full"][dk]) for s in sts]
            res = _analyze(bright, dark, exposure_s=exp if all(math.isfinite(e) for e in exp) else None,
                           photons=photons, adc_lsb_uv=_adc_lsb_uv(run, stored), analog_gain=g,
                           signal_se=[signal_se(s) for s in sts])
        out.append(PtcGroup(g, sts, res, stored, exp, light, photons))
    return out


PTC_COLUMNS = ("analog_gain", "stage_index", "stage", "exposure_s", "light", "photons", "mean_dn", "dark_mean_dn",
               "signal_dn", "variance_dn2", "variance_se_dn2", "dark_variance_dn2", "frac_at_max", "status",
               "reason", "bright_variance_dn2", "n_pixels", "n_frames", "dark_n_frames", "signal_se_dn")


def ptc_export(run, groups: list[PtcGroup]) -> tuple[list[dict], list[str]]:
    """``ptc_rows`` as ptc.csv and report.h5 hold them: every column named with its unit
    (``light`` -> ``light_<the light source's unit>``, ``photons`` -> ``photons_per_pixel``;
    ``ares ptc`` reads both spellings)."""
    rename = {"light": labels.with_unit("light", run.setting_units.get("light", "")), "photons": "photons_per_pixel"}
    rows = [{rename.get(k, k): v for k, v in r.items()} for r in ptc_rows(groups)]
    return rows, [rename.get(c, c) for c in PTC_COLUMNS]


def ptc_rows(groups: list[PtcGroup]) -> list[dict]:
    """One row per PTC level: the stage numbers, dark-subtracted signal/variance, SE, status."""
    rows = []
    for g in groups:
        lv, dk = ptc_level_keys(g.stages)
        for i, st in enumerate(g.stages):
            full = st["views"]["full"]
            b, d = levelstats(full[lv]), levelstats(full[dk])
            status, reason = g.status(i)
            rows.append({
                "analog_gain": g.analog_gain, "stage_index": st["index"], "stage": st["name"],
                "exposure_s": g.exposure_s[i], "light": g.light[i],
                "photons": g.photons[i] if g.photons is not None else None,
                "mean_dn": b.mean, "dark_mean_dn": d.mean, "signal_dn": b.mean - d.mean,
                "variance_dn2": b.var - d.var, "variance_se_dn2": math.hypot(b.var_se, d.var_se),
                "dark_variance_dn2": d.var, "frac_at_max": b.frac_at_max, "status": status, "reason": reason,
                # the raw numbers `ares ptc` needs to redo the analysis from this table alone
                "bright_variance_dn2": b.var, "n_pixels": b.n_pixels, "n_frames": b.n_frames,
                "dark_n_frames": d.n_frames, "signal_se_dn": signal_se(st),
            })
    return rows


# ------------------------------------------------------------------ components

COMPONENT_COLUMNS = ("stage_index", "stage", "scene", "view", "part", "component", "description", "value", "se",
                     "unit", "note")


def _ordered(comps: dict) -> list[str]:
    order = [c for c in COMPONENTS + EXTRA_COMPONENTS if c in comps]
    return order + [c for c in comps if c not in order]


def component_rows(stage: dict, views: list[str] | None = None) -> list[dict]:
    """Every component of every view of a stage: the 13-component model for a flat stage
    with a matched dark ("components"), the dark ANOVA ("dark_components") and the ANOVA of
    the flat stack itself ("flat_anova") where the stage holds them."""
    rows = []
    for view, v in stage["views"].items():
        if views is not None and view not in views:
            continue
        for part in COMPONENT_PARTS:
            comps = v.get(part)
            if not isinstance(comps, dict):
                continue
            for c in _ordered(comps):
                e = comps[c] if isinstance(comps[c], dict) else {}
                rows.append({"stage_index": stage["index"], "stage": stage["name"], "scene": stage.get("scene"),
                             "view": view, "part": part, "component": c,
                             "description": COMPONENT_LABELS.get(c, "") + (
                                 f" ({PART_NOTES[part]})" if part in PART_NOTES and "components_masked" in v else ""),
                             "value": e.get("value"),
                             "se": e.get("se"), "unit": e.get("unit", ""), "note": e.get("note", "")})
    return rows


LEVEL_COLUMNS = ("stage_index", "stage", "scene", "view", "n_pixels", "n_frames", "mean_dn", "var_dn2",
                 "spatial_var_dn2", "frac_at_max", "frac_at_min", "dark_n_frames", "dark_mean_dn", "dark_var_dn2",
                 "dark_spatial_var_dn2", "dark_frac_at_max", "dark_frac_at_min", "seconds")


def level_rows(stage: dict) -> list[dict]:
    """Per view of a stage: the level statistics summary.csv leaves out (every view, spatial
    variance, clip fractions, the matched dark's statistics, stage duration)."""
    rows = []
    for view, v in stage["views"].items():
        lv, dk = v.get("level") or {}, v.get("dark_level") or {}
        r = {"stage_index": stage["index"], "stage": stage["name"], "scene": stage.get("scene"), "view": view,
             "seconds": (stage.get("timing") or {}).get("seconds")}
        for k in ("n_pixels", "n_frames", "mean_dn", "var_dn2", "spatial_var_dn2", "frac_at_max", "frac_at_min"):
            r[k] = lv.get(k)
            if k != "n_pixels":
                r["dark_" + k] = dk.get(k)
        rows.append(r)
    return rows


def mid_stage(run) -> dict | None:
    """The decomposition stage the runner chose, else the flat stage nearest half the
    highest unclipped signal (as ``ares.results.analyses.mid_level_stage``)."""
    name = (run.analyses.get("decomposition") or {}).get("stage")
    for st in run.stages:
        if st["name"] == name:
            return st
    flats = [s for s in run.stages if s.get("scene") == "flat"]
    if not flats:
        return run.stages[len(run.stages) // 2] if run.stages else None

    def signal(s):
        full = s["views"]["full"]
        return full["level"]["mean_dn"] - (full["dark_level"]["mean_dn"] if "dark_level" in full else 0.0)

    ok = [s for s in flats if (s["views"]["full"]["level"].get("frac_at_max") or 0) < 0.002]
    if not ok:
        return flats[len(flats) // 2]
    top = max(signal(s) for s in ok)
    return min(ok, key=lambda s: abs(signal(s) - top / 2))


def dark_stage(run) -> dict | None:
    """The first dark stage (the one a PTC reuses as its matched dark); a sensor test
    pattern (``test_mode`` set and not 0, e.g. the ADC ramp) is not a dark image."""
    return next((s for s in run.stages if s.get("scene") == "dark"
                 and not (s.get("settings") or {}).get("test_mode")), None)


# ------------------------------------------------------------------ key figures


def _snr_max(res: PtcResult, well_e: float, well_se: float = 0.0) -> Estimate:
    """SNR max (measured) judged against sqrt of the full well ``well_e`` (``PtcResult.snr_max``)."""
    return res.snr_max(well_e, well_se)


def _flat_estimates(d: dict, prefix: str = "") -> list[tuple[str, dict]]:
    out = []
    for k, v in d.items():
        if isinstance(v, dict) and "value" in v and "unit" in v:
            out.append((prefix + k, v))
        elif isinstance(v, dict):
            out += _flat_estimates(v, f"{prefix}{k}.")
    return out


def compute_key_figures(run, groups: list[PtcGroup] | None = None) -> dict:
    """``{name: {label, value, se, unit, note, source}}`` in report order."""
    groups = ptc_groups(run) if groups is None else groups
    kf: dict[str, dict] = {}
    stored = run.analyses.get("ptc") or {}
    g0 = next((g for g in groups if g.result is not None and g.is_curve), None)
    have_stored = "gain_dn_per_e" in stored
    src = "scan_results.json: ptc" if have_stored else "computed by the report from the completed stages"
    res = g0.result if g0 is not None else None

    def pick(key: str, fallback: Estimate | None) -> Estimate:
        if have_stored and key in stored:
            return est(stored[key])
        return fallback if fallback is not None else Estimate.na("no photon-transfer data")

    if have_stored or res is not None:
        ag = stored.get("analog_gain", g0.analog_gain if g0 else 1.0)
        kf["gain_dn_per_e"] = _entry(labels.figure_name("gain_dn_per_e") + (f" (analog gain x{ag:g})" if ag != 1 else ""),
                                     pick("gain_dn_per_e", res and res.gain_dn_per_e), src)
        stmt = (stored.get("gain_headline") or {}).get("statement")
        if stmt and kf["gain_dn_per_e"]["value"] is not None:  # beside 4.0 Eq. 50 (ares.analysis.ptc.gain_compare)
            kf["gain_dn_per_e"]["note"] = stmt
        kf["gain_e_per_dn"] = _entry(labels.figure_name("gain_e_per_dn"), pick("gain_e_per_dn", res and res.gain_e_per_dn), src)
        kf["conversion_gain_uv_per_e"] = _entry(
            labels.figure_name("conversion_gain_uv_per_e"), pick("conversion_gain_uv_per_e", res and res.conversion_gain_uv_per_e), src)
        if res is not None:
            for key in ("gain_origin_dn_per_e", "gain_astier_dn_per_e"):
                kf[key] = _entry(labels.figure_name(key), getattr(res, key), "PTC recomputed")
        for key in ("read_noise_e", "read_noise_dn"):  # distinct names: with / without quantization noise
            kf[key] = _entry(labels.PTC_LABELS[key], pick(key, res and getattr(res, key)), src)
        kf["full_well_e"] = _entry(labels.figure_name("full_well_e"), pick("full_well_e", res and res.full_well), src)
        fwd = stored.get("full_well_definitions") if have_stored else None
        fw = {k: est(v) for k, v in fwd.items()} if fwd else (res.full_well_e if res is not None else {})
        for k, e in fw.items():
            if k == "ptc_turnoff":  # run directories before issue 34: the turnoff is one figure, below
                continue
            kf[f"full_well_e.{k}"] = _entry(FULL_WELL_LABELS.get(k, f"full well ({k})"), e, src)
        for key in ("turnoff_dn", "turnoff_e"):  # one turnoff, SE from the level spacing
            kf[key] = _entry(labels.PTC_LABELS[key], pick(key, res and getattr(res, key)), src)
        from ares.report.headline import full_well_note, same_point

        for key, text in (("full_well_e", full_well_note(stored)), ("turnoff_e", same_point(stored))):
            if text and kf.get(key) and kf[key]["value"] is not None:  # said beside the figure, as the terminal says it
                kf[key]["note"] = f"{text}; {kf[key]['note']}"
        kf["dynamic_range_db"] = _entry(labels.figure_name("dynamic_range_db"), pick("dynamic_range_db", res and res.dynamic_range_db), src)
        if res is not None:
            well = est(kf["full_well_e"])  # the charge capacity: no SNR above its square root
            s = pick("snr_max", _snr_max(res, well.value if well.available else math.nan, well.se))
            kf["snr_max"] = _entry(labels.figure_name("snr_max"), s, src if have_stored and "snr_max" in stored
                                   else "PTC recomputed")
            if s.available:
                kf["snr_max_db"] = _entry(labels.figure_name("snr_max"), snr_db(s, "20 log10 SNR max (measured)"),
                                          "PTC recomputed")
            fwv = fw.get("saturation_capacity")  # (the datasheet's SNR_max, on its own mu_e.sat, is its own figure)
            if fwv is not None and fwv.available:
                kf["snr_max_emva"] = _entry(labels.figure_name("snr_max_emva"),
                                            Estimate(math.sqrt(fwv.value), fwv.se / (2 * math.sqrt(fwv.value))
                                                     if math.isfinite(fwv.se) else math.nan, "",
                                                     "sqrt(saturation capacity)"), "PTC recomputed")
            for k, e in res.noise_model.items():
                kf[f"noise_model.{k}"] = _entry(labels.FIGURES.get(f"noise_model.{k}", (k,))[0], e, "PTC recomputed")
        q = pick("qe", res and res.qe)
        if q.available and q.unit in ("", "1"):  # a fraction (run directories before QE was in %)
            q = Estimate(100 * q.value, 100 * q.se, "%", q.note)
        kf["qe"] = _entry(labels.figure_name("qe"), q, src)
        kf["linearity_error_pct"] = _entry(labels.figure_name("linearity_error_pct"),
                                           pick("linearity_error_pct", res and res.linearity_error_pct), src)
    gk = kf.get("gain_dn_per_e")
    kf.update(nonuniformity_figures(run, est(gk) if gk and gk["value"] is not None else None))
    if not run.complete and kf:
        for k, v in kf.items():
            if k.startswith(("full_well", "dynamic_range", "snr_max")) and v["value"] is not None:
                v["note"] = "partial run, saturation may be missing; " + v["note"]
    for name, r in (stored.get("by_analog_gain") or {}).items():
        for key, lab in labels.BY_ANALOG_GAIN.items():
            if key in r:
                kf[f"{key}@{name}"] = _entry(f"{lab} at analog gain {name}", est(r[key]), "scan_results.json: ptc")
    if not any(e.get("value") is not None for key, e in _flat_estimates(run.analyses.get("dark_current") or {})
               if "rate" in key):
        gk = kf.get("gain_dn_per_e")
        gain = Estimate(_nan(gk["value"]), _nan(gk["se"]), "DN/e-") if gk else None
        kf.update(dark_current_figures(run, gain))
    # every other scan-level analysis: its estimates (dark current, doubling temperature ...)
    for aname, a in run.analyses.items():
        if aname in ("ptc", "decomposition") or not isinstance(a, dict):
            continue
        if a.get("status") in ("not available", "error"):
            continue
        for key, e in _flat_estimates(a):
            if e.get("value") is None and not (e.get("unit") == "e-/s" and
                                               str(e.get("note") or "").startswith("the scan measures no gain")):
                continue  # not available: in scan_results.json with its reason (a dark current's e-/s beside
                # its DN/s says why it is missing: a gain is needed)
            label = analysis_label(aname, key)
            if aname == "dark_current" and "." not in key and a.get("temperature_c") is not None:
                label += f" at {a['temperature_c']:g} °C"  # a dark current is only meaningful at its temperature
            kf[f"{aname}.{key}"] = _entry(label, est(e), f"scan_results.json: {aname}")
            if e.get("verdict") and e["verdict"] != kf[f"{aname}.{key}"]["verdict"]:  # a verdict an Estimate does
                kf[f"{aname}.{key}"]["verdict"] = e["verdict"]  # not hold ("drift not separated", "precision not enough")
        if aname == "defects" and isinstance(a.get("counts"), dict) and a["counts"].get("total") is not None:
            kf.update(defect_count_figures(a))
    dec = run.analyses.get("decomposition")
    if isinstance(dec, dict) and dec.get("masked_pixels") is not None:
        classes = ", ".join(f"{k} {v}" for k, v in (dec.get("mask_classes") or {}).items())
        kf["decomposition.masked_pixels"] = _entry(
            labels.MASKED_PIXELS, Estimate.count(dec["masked_pixels"], "pixels",
                                           f"mask from {dec.get('mask_source')}" + (f": {classes}" if classes else "")
                                           + "; not the defect analysis's classes"),
            "scan_results.json: decomposition")
    return kf


def defect_count_figures(a: dict) -> dict:
    """The defect analysis's pixel count per class and in all, each class not tested with its
    reason (key figures, hence key_figures.csv and report.h5)."""
    out = {}
    why = a.get("unavailable") if isinstance(a.get("unavailable"), dict) else {}
    part = {c: w for c, w in (a.get("detection") or {}).items() if str(w).startswith("incomplete")}

    def count(n, unit: str, note: str, partial: str) -> Estimate:  # a count found incomplete: a lower limit
        return Estimate.limit(n, "lower", unit, f"{note}; at least {n}, {partial}") if partial else \
            Estimate.count(n, unit, note)

    for cls, n in a["counts"].items():
        if cls == "total":
            continue
        unit = labels.defect_count_unit(cls)
        e = (count(n, unit, f"class {cls}", part.get(cls, "")) if n is not None else
             Estimate.na(why.get(cls) or "not tested by this scan", unit))
        out[f"defects.{cls}"] = _entry(f"{labels.DEFECTIVE_PIXELS}: {cls}", e, "scan_results.json: defects")
    out["defects.total"] = _entry(labels.DEFECTIVE_PIXELS, count(a["counts"]["total"], "pixels",
                                                                 "all classes (see the defects page)",
                                                                 "; ".join(f"{c} {w}" for c, w in part.items())),
                                  "scan_results.json: defects")
    return out


def nonuniformity_figures(run, gain: Estimate | None) -> dict:
    """DSNU (e- rms and DN rms) and PRNU (% rms) of the decomposed stage, with defects
    excluded and with every pixel, each under its own name (``ares.report.headline``, the
    terminal's and the window's figures); each with its SE or the reason it is not available."""
    from ares.report.headline import NO_MASK, nonuniformity

    st = mid_stage(run)
    if st is None:
        return {}
    mtf = (getattr(run, "analyses", None) or {}).get("mtf")
    src = f"stage {st['name']}"
    if isinstance(mtf, dict) and st["name"] in (mtf.get("stages") or {}):  # an edge target, not a uniform flat
        why = f"stage {st['name']} images a slanted edge (the mtf analysis), not a uniform flat"
        units = {"dsnu_e": "e-", "dsnu_dn": "DN", "dsnu_all_e": "e-", "dsnu_all_dn": "DN", "prnu_pct": "%",
                 "prnu_all_pct": "%"}
        return {k: _entry(labels.figure_name(k), Estimate.na(why, u), src) for k, u in units.items()}
    full = st["views"]["full"]
    comp = full.get("components") or {}
    if (gain is None or not gain.available) and (comp.get("G") or {}).get("value") is not None:
        g = est(comp["G"])  # the stage's own gain (flat minus dark) when no PTC measured K
        gain = Estimate(g.value, g.se, "DN/e-", "stage gain G")
    elif gain is not None:
        gain = Estimate(gain.value, gain.se, gain.unit, "K")
    dec = (getattr(run, "analyses", None) or {}).get("decomposition") or {}
    why = dec.get("mask_note") or f"{NO_MASK} ({labels.MASK_POLICY})"
    figs = nonuniformity(full.get("components_masked"), comp, gain, st["name"], why, st.get("scene"))
    return {k: _entry(labels.figure_name(k), e, src) for k, e in figs.items()}


# ------------------------------------------------------------------ dark series


# ------------------------------------------------------------------ ADC curves
