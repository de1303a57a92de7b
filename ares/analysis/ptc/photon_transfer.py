"""Photon transfer: conversion gain, read noise, saturation, full well, DR, SNR, linearity.

Input: one ``LevelStats`` per bright level and the dark ``LevelStats`` at the same
exposure (``ares.analysis.ptc.levels``), in any order. Signal ``S = mu_y - mu_dark`` and
temporal variance ``V = s2_y - s2_dark`` (SCIENCE.md "Photon transfer"). Levels are taken
in signal order whatever the input order; every level gets a status:

- ``"fit"``: used by the gain fits (at most ``fit_fraction`` of saturation);
- ``"valid"``: on the curve above the fit range (used for SNR and the noise model);
- ``"excluded"``: non-finite, no significant signal, clipped (EMVA 1288 4.0 Section 6.6
  histogram criterion), collapsed, non-monotonic, beyond the PTC turnoff, or a wild row among
  the fitted levels (``headline.drop_outliers``) -- with the reason stated; excluded levels
  are never fitted.

Saturation is *bracketed* (``ares.analysis.ptc.saturation``): it lies between the last level
on the curve and the first clipped one. Every full-well definition is checked against the
bracket, and a run that never saturates gets no full well and no dynamic range.

Every decision (the turnoff, the gain model's residual tests) uses errors that describe the
levels' own scatter (``turnoff.decision_errors``: the counts' errors unless the measured
scatter disagrees, and the result says which). The headline gain is the Astier 2019 fit
wherever >= 5 levels determine it (``choose_gain_model``: the line is its a00 = 0 case), the
line only where Astier's K is not measured and its curvature not significant; the EMVA 1288
4.0 Linear Eq. 51 check says whether the linear model holds. ``sanity`` marks figures no
sensor gives not available, with the reason. Units: ``K`` DN/e- (EMVA), its inverse e-/DN,
conversion gain uV/e- = K * LSB_uV / analog gain; read noise EMVA 4.0 Eqs. 53-54.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ares.analysis.stats.estimate import LIMIT_NSIGMA, Estimate
from ares.analysis.ptc.levels import LevelStats
from ares.analysis.ptc.fit import (AstierFit, GainModel, LocalSlopeCheck, local_slope_check, local_slope_check_text,
                                   max_relative_deviation, origin_fit)
from ares.analysis.ptc.headline import drop_outliers, gain_estimates
from ares.analysis.ptc.noise_figures import loglog_slopes, noise_model, read_noise, sensitivity_threshold
from ares.analysis.ptc.saturation import SaturationBracket, saturation_bracket
from ares.analysis.ptc.turnoff import DecisionErrors, decision_errors, lsst_pivot, ptc_turnoff_found
from ares.analysis.ptc.saturation import _full_well, _turnoffs
from ares.analysis.ptc.saturation import PtcLevel

__all__ = ["PtcLevel", "PtcResult", "analyze_ptc", "classify_levels", "loglog_slopes"]


@dataclass
class PtcResult:
    levels: list[PtcLevel]
    gain_dn_per_e: Estimate  # the model the data chose (gain_model)
    gain_e_per_dn: Estimate
    conversion_gain_uv_per_e: Estimate
    gain_origin_dn_per_e: Estimate  # EMVA 1288 origin fit
    gain_astier_dn_per_e: Estimate
    astier: AstierFit | None
    gain_vs_range: dict[str, Estimate]
    read_noise_dn: Estimate
    read_noise_e: Estimate
    read_noise_is_upper_limit: bool
    saturation_index: int  # EMVA 3.0: max temporal variance (input index, -1: none)
    full_well_e: dict[str, Estimate]  # every definition, each checked against the bracket
    dynamic_range: Estimate
    dynamic_range_db: Estimate
    sensitivity_threshold_e: Estimate
    qe: Estimate
    linearity_error_pct: Estimate
    snr: dict[str, np.ndarray]
    noise_model: dict[str, Estimate] = field(default_factory=dict)
    zones: dict[str, Estimate] = field(default_factory=dict)
    saturation: SaturationBracket | None = None
    full_well: Estimate = field(default_factory=lambda: Estimate.na("not computed", "e-"))  # headline
    gain_model: GainModel | None = None
    linearity_check: LocalSlopeCheck | None = None
    gain_wls_dn_per_e: Estimate = field(default_factory=lambda: Estimate.na("not computed", "DN/e-"))
    turnoff_dn: Estimate = field(default_factory=lambda: Estimate.na("not computed", "DN"))  # headline turnoff
    turnoff_e: Estimate = field(default_factory=lambda: Estimate.na("not computed", "e-"))
    turnoff_definitions_dn: dict[str, Estimate] = field(default_factory=dict)  # published definitions by name
    # Eq. 51 as written (EMVA 1288 4.0 Linear Section 6.6), shown beside ``linearity_check``
    # (ARES's variant, option eq51_noise_floor), never replaced by it
    linearity_check_text: LocalSlopeCheck | None = None
    errors: DecisionErrors | None = None  # the variance errors the decisions used, and why (issue 48)

    def gain_headline(self) -> dict:
        """Which estimator gives the headline K and why (one sentence)."""
        k = self.gain_dn_per_e
        if not k.available:
            return {"estimator": None, "reason": k.note}
        reason = k.note.split("; ")[0]
        if reason.startswith("unweighted line"):
            return {"estimator": "ols", "reason": reason}
        is_ast = (self.gain_astier_dn_per_e.available and k.value == self.gain_astier_dn_per_e.value)
        return {"estimator": "astier" if is_ast else "line", "reason": reason}

    def snr_max(self, well_e: float | None = None, well_se: float | None = None) -> Estimate:
        """SNR max (measured): the largest signal / temporal noise on the curve, its SE from
        the variance's chi-square scatter, judged against sqrt of the full well (``well_e``,
        default the headline full well): above it the noise was mis-measured."""
        from ares.analysis.stats.physical import snr_in_range

        snr = self.snr.get("snr")
        if snr is None or not len(snr):
            return Estimate.na("no valid PTC level", "")
        if well_e is None:
            fw = self.full_well
            well_e, well_se = (fw.value, fw.se) if fw.available else (math.nan, 0.0)
        i = int(np.argmax(snr))
        se = self.snr["snr_se"][i] if "snr_se" in self.snr else math.nan
        s = Estimate(float(snr[i]), float(se), "",
                     f"max measured signal / temporal noise (at {self.snr['signal_dn'][i]:.5g} DN)")
        return snr_in_range(s, well_e, "SNR max (measured)", charge_se=well_se or 0.0)

    def used(self, status: str = "fit") -> list[PtcLevel]:
        return [lv for lv in self.levels if lv.status == status]

    def to_dict(self, names: Sequence[str]) -> dict:
        """The JSON form shown everywhere (scan results, ``ares ptc --json``); ``names[i]``
        names input level i (a stage, a table line)."""
        br, k, lin = self.saturation, self.gain_dn_per_e, self.linearity_check

        def e_of(dn: float) -> float | None:
            return dn / k.value if br is not None and br.reached and k.available and math.isfinite(dn) else None

        def name(i: int) -> str | None:
            return names[i] if i >= 0 else None

        return {
            "gain_dn_per_e": self.gain_dn_per_e.to_dict(), "gain_e_per_dn": self.gain_e_per_dn.to_dict(),
            "gain_line_dn_per_e": self.gain_wls_dn_per_e.to_dict(),
            # the other estimators the PTC plot draws, so no surface shows a K the JSON lacks
            "gain_origin_dn_per_e": self.gain_origin_dn_per_e.to_dict(),
            "gain_astier_dn_per_e": self.gain_astier_dn_per_e.to_dict(),
            "gain_model": self.gain_model.to_dict() if self.gain_model else None,
            "gain_headline": self.gain_headline(),
            "linearity_check": {"mean_rel_dev": lin.mean_rel_dev if math.isfinite(lin.mean_rel_dev) else None,
                                "holds": lin.holds, "note": lin.note} if lin else None,
            "linearity_check_text": ({"mean_rel_dev": self.linearity_check_text.mean_rel_dev
                                      if math.isfinite(self.linearity_check_text.mean_rel_dev) else None,
                                      "holds": self.linearity_check_text.holds,
                                      "note": self.linearity_check_text.note} if self.linearity_check_text else None),
            "conversion_gain_uv_per_e": self.conversion_gain_uv_per_e.to_dict(),
            "read_noise_dn": self.read_noise_dn.to_dict(), "read_noise_e": self.read_noise_e.to_dict(),
            "read_noise_is_upper_limit": self.read_noise_is_upper_limit,
            # the charge capacity (saturated plateau / K, else the saturation bracket); every
            # other definition, each checked against the bracket, under full_well_definitions
            "full_well_e": self.full_well.to_dict(),
            "saturation_capacity_e": self.full_well_e["saturation_capacity"].to_dict(),
            "full_well_definitions": {k_: v.to_dict() for k_, v in self.full_well_e.items()},
            "saturation": None if br is None else {
                "reached": br.reached, "reason": br.reason, "last_unclipped_stage": name(br.last_ok),
                "first_clipped_stage": name(br.first_clipped), "low_e": e_of(br.low_dn), "high_e": e_of(br.high_dn)},
            "sensitivity_threshold_e": self.sensitivity_threshold_e.to_dict(),
            "dynamic_range_db": self.dynamic_range_db.to_dict(), "qe": self.qe.to_dict(),
            "linearity_error_pct": self.linearity_error_pct.to_dict(),
            "snr_max": self.snr_max().to_dict(),
            "saturation_stage": name(self.saturation_index),
            "turnoff_dn": self.turnoff_dn.to_dict(), "turnoff_e": self.turnoff_e.to_dict(),
            "turnoff_definitions_dn": {k_: v.to_dict() for k_, v in self.turnoff_definitions_dn.items()},
            "decision_errors": None if self.errors is None else {
                "source": self.errors.source, "note": self.errors.note,
                "scatter_ratio": self.errors.scatter.ratio if self.errors.scatter.available else None},
            "level_status": [{"stage": names[lv.index], "status": lv.status, "reason": lv.reason}
                             for lv in self.levels],
        }

    def excluded(self) -> list[tuple[int, str]]:
        return [(lv.index, lv.reason) for lv in self.levels if lv.status == "excluded"]


def _inv(e: Estimate, unit: str, note: str = "") -> Estimate:
    if not e.available or e.value == 0:
        return Estimate.na("gain not available", unit)
    return Estimate(1.0 / e.value, e.se / e.value / e.value, unit, note)


def _nominal(n: int, exposure_s, photons):
    """The illumination axis (photons, else exposure) when every level has one."""
    for x in (photons, exposure_s):
        if x is not None:
            a = np.asarray(x, float)
            if a.size == n and np.all(np.isfinite(a)):
                return a
    return None


def classify_levels(bright: Sequence[LevelStats], dark: Sequence[LevelStats],
                    exposure_s=None, photons=None, clip_limit: float = 0.002,
                    fit_fraction: float = 0.7, nsigma: float = 4.0, signal_se=None,
                    counts_known: bool = True) -> tuple[list[PtcLevel], SaturationBracket, DecisionErrors]:
    n = len(bright)
    S = np.array([b.mean - d.mean for b, d in zip(bright, dark)], float)
    V = np.array([b.var - d.var for b, d in zip(bright, dark)], float)
    dof = np.array([min(b.dof, d.dof) for b, d in zip(bright, dark)], float)
    Vse = np.sqrt(np.array([b.var_se**2 + d.var_se**2 for b, d in zip(bright, dark)], float))
    t = np.full(n, math.nan) if exposure_s is None else np.asarray(exposure_s, float)
    p = np.full(n, math.nan) if photons is None else np.asarray(photons, float)
    nominal = _nominal(n, exposure_s, photons)
    status = ["fit"] * n
    reason = [""] * n
    clipped = np.zeros(n, bool)
    signif = np.isfinite(S) & np.isfinite(V) & (S > 0) & (V > 3 * Vse)
    s_min_signif = float(S[signif].min()) if signif.any() else math.inf
    for i in range(n):
        b = bright[i]
        if not (math.isfinite(S[i]) and math.isfinite(V[i])):
            status[i], reason[i] = "excluded", "non-finite mean or variance"
        elif not math.isfinite(Vse[i]):
            status[i], reason[i] = "excluded", f"variance {V[i]:.3g} DN^2 beyond float64 arithmetic (its square overflows)"
        elif b.frac_at_max - dark[i].frac_at_max > clip_limit:
            # pixels already at the maximum code in the dark (hot, stuck high) are defects,
            # not saturation: only the excess over the dark's fraction counts
            status[i], clipped[i] = "excluded", True
            reason[i] = (f"clipped: {100 * (b.frac_at_max - dark[i].frac_at_max):.3g} % of samples at the maximum "
                         f"code above the dark's (limit {100 * clip_limit:g} %, EMVA 1288 4.0 Section 6.6)")
        elif b.frac_at_min > clip_limit:
            status[i], reason[i] = "excluded", f"clipped: {100 * b.frac_at_min:.3g} % of samples at code 0"
        elif not S[i] > 0:
            status[i], reason[i] = "excluded", f"no signal above dark (S = {S[i]:.3g} DN)"
        elif not signif[i]:
            if S[i] > s_min_signif:  # brighter than a level with shot noise: the variance collapsed
                status[i], clipped[i] = "excluded", True
                reason[i] = (f"collapsed: temporal variance {V[i]:.3g} DN^2 not above dark at S = {S[i]:.5g} DN "
                             "(fully saturated)")
            else:
                status[i], reason[i] = "excluded", (
                    f"no significant signal: V = {V[i]:.3g} ± {Vse[i]:.2g} DN^2 above dark at S = {S[i]:.3g} DN")
    if nominal is not None:  # the signal must rise with the illumination
        best, best_i = -math.inf, -1
        for i in np.argsort(nominal, kind="stable"):
            if status[i] == "excluded":
                continue
            if S[i] <= best and nominal[i] > nominal[best_i]:
                status[i], reason[i] = "excluded", (
                    f"non-monotonic: signal {S[i]:.5g} DN not above {best:.5g} DN of level {best_i} "
                    "at lower illumination")
                continue
            if S[i] > best:
                best, best_i = S[i], i
    # a level brighter (by illumination) than a clipped one is beyond saturation too
    if nominal is not None and clipped.any():
        x_clip = nominal[clipped].min()
        for i in range(n):
            if status[i] != "excluded" and nominal[i] > x_clip:
                status[i], clipped[i] = "excluded", True
                reason[i] = "beyond saturation: brighter than a clipped level"
    cand = sorted((i for i in range(n) if status[i] != "excluded"), key=lambda i: S[i])
    # the scatter is measured on the curve: the levels up to the highest variance (a wild
    # row beyond the turnover is one point of many: the MAD ignores it)
    on = np.zeros(n, bool)
    if cand:
        top = int(np.argmax(V[cand]))
        on[cand[:top + 1] if top + 1 >= 6 else cand] = True
    de = decision_errors(S, V, Vse, signal_se, counts_known, curve=on, offset=[d.var for d in dark])
    if de.source == "none":  # no errors at all: the errorless rule (LSST cp_pipe, named)
        n_on = seen = lsst_pivot(V[cand]) if cand else 0
        found = None
        why = "the variance decreases at two consecutive levels (LSST cp_pipe's errorless PTC cut)"
    else:
        found = ptc_turnoff_found(S[cand], V[cand], de.se[cand], nsigma=nsigma) if cand else None
        n_on, seen = found if found is not None else (0, 0)
        why = (f"variance below the curve of the levels under it, or below their maximum, by > {nsigma:g} SE of the "
               f"{'measured scatter' if de.source == 'measured' else 'counts'}, confirmed by the next levels")
    for i in cand[n_on:]:
        status[i], clipped[i] = "excluded", True
        reason[i] = f"beyond the PTC turnoff: the curve followed from below first departs ({why}) at S = {S[cand[n_on]]:.5g} DN"
    on_curve = np.array([st != "excluded" for st in status])
    br = saturation_bracket(S, clipped, on_curve, nominal)
    if cand and seen > n_on and seen < len(cand):  # where the departure was seen, for the turnoff's SE
        br = dataclasses.replace(br, seen_dn=float(S[cand[seen]]))
    if found is not None and 0 <= found.amb_lo <= found.amb_hi < len(cand):
        br = dataclasses.replace(br, plausible_dn=(float(S[cand[found.amb_lo]]), float(S[cand[found.amb_hi]])),
                                 charge_plausible_dn=(float(S[cand[min(found.lo_wide, found.amb_lo)]]),
                                                      float(S[cand[found.amb_hi]])))
    if br.reached:
        for i in cand[:n_on]:
            if S[i] > fit_fraction * br.low_dn:
                status[i], reason[i] = "valid", f"above {100 * fit_fraction:g} % of saturation: not fitted"
    # each signal's SE: the given one (the frame means' scatter), else the temporal noise of the
    # bright and dark means over their pixels and frames
    def mean_var(x: LevelStats) -> float:  # the variance of a level's mean over its pixels and frames
        n = x.n_pixels * x.n_frames
        return x.var / n if n and math.isfinite(x.var) and x.var >= 0 else math.nan

    s_se = [float(signal_se[i]) if signal_se is not None and math.isfinite(signal_se[i]) else
            math.sqrt(mean_var(b) + mean_var(d)) if math.isfinite(mean_var(b) + mean_var(d)) else math.nan
            for i, (b, d) in enumerate(zip(bright, dark))]
    levels = [PtcLevel(i, float(S[i]), float(V[i]), float(Vse[i]), float(dof[i]), float(bright[i].var),
                       float(bright[i].spatial_var), float(bright[i].frac_at_max), float(t[i]), float(p[i]),
                       status[i], reason[i], bool(clipped[i]), float(de.se[i]), s_se[i]) for i in range(n)]
    return levels, br, de


def analyze_ptc(bright: Sequence[LevelStats], dark: Sequence[LevelStats], *, exposure_s=None,
                photons=None, clip_limit: float = 0.002, fit_fraction: float = 0.7,
                adc_lsb_uv: float | None = None, analog_gain: float = 1.0,
                dark_exposure_s=None, read_dark: Sequence[LevelStats] | None = None,
                signal_se=None, counts_known: bool = True) -> PtcResult:
    """Full photon-transfer analysis. ``dark[i]`` is the dark level at ``bright[i]``'s
    exposure. ``read_dark``/``dark_exposure_s`` (default: ``dark``/``exposure_s``) give
    the dark levels for sigma_y.dark.

    ``signal_se[i]`` (DN, optional): standard error of level i's signal not shared by all
    levels -- e.g. from the scatter of the bright stack's frame means (a frame-global
    offset moves the mean but is removed from the variance)."""
    if len(bright) != len(dark):
        raise ValueError("one dark level per bright level is required")
    levels, br, de = classify_levels(bright, dark, exposure_s, photons, clip_limit, fit_fraction,
                                     signal_se=signal_se, counts_known=counts_known)
    fit, wild = drop_outliers([lv for lv in levels if lv.status == "fit"])
    if wild:  # (wild rows among the fitted levels: excluded, each with its reason)
        out = {lv.index: lv for lv in wild}
        levels = [out.get(lv.index, lv) for lv in levels]
        fit = [lv for lv in levels if lv.status == "fit"]
    good = sorted((lv for lv in levels if lv.status in ("fit", "valid")), key=lambda lv: lv.signal)
    fit_note = (f"up to {100 * fit_fraction:g} % of saturation" if br.reached else
                "all levels (saturation not reached)")
    gain, k_wls, k_org, k_ast, gm = gain_estimates(fit, fit_note, de.source)
    # decided on the errors the turnoff used (the measured scatter where it disagrees with the counts)
    lin = local_slope_check([lv.signal for lv in fit], [lv.variance for lv in fit],
                            None if de.source == "none" else [lv.decision_se for lv in fit], k_wls.value,
                            errors_name="counts' errors" if de.source == "counts" else
                            "measured-scatter errors the turnoff used")
    e_per_dn = _inv(gain, "e-/DN", "1/K")
    if adc_lsb_uv is not None and gain.available:
        cg = Estimate(gain.value * adc_lsb_uv / analog_gain, gain.se * adc_lsb_uv / analog_gain, "uV/e-",
                      f"K * {adc_lsb_uv:g} uV/DN / analog gain {analog_gain:g}")
    else:
        cg = Estimate.na("ADC LSB (uV) not given", "uV/e-")

    gvr: dict[str, Estimate] = {}  # gain against fit range (diagnostic)
    if br.reached:
        for f in (0.3, 0.5, 0.7):
            sel = [lv for lv in good if lv.signal <= f * br.low_dn]
            lf = origin_fit([lv.signal for lv in sel], [lv.variance for lv in sel], [lv.variance_se for lv in sel])
            gvr[f"0-{int(f * 100)}%"] = (Estimate(lf.slope, lf.slope_se, "DN/e-", f"origin fit 0-{int(f * 100)} % "
                                                  "of saturation") if math.isfinite(lf.slope) else
                                         Estimate.na(f"too few levels ({lf.n})", "DN/e-"))

    rd = list(read_dark) if read_dark is not None else list(dark)
    rt = dark_exposure_s if read_dark is not None else exposure_s
    rn_dn, rn_e, upper = read_noise(rd, rt, gain)

    xlin = photons if photons is not None else exposure_s
    fw, head, sat_i = _full_well(levels, br, gain, clip_limit, xlin, photons)

    # QE (responsivity R = slope of S vs photons, origin fit over the fit range) / K (Eq. 52)
    if photons is not None and gain.available and fit:
        R = origin_fit([lv.photons for lv in fit], [lv.signal for lv in fit])
        if R.slope > 0 and math.isfinite(R.slope):
            qv = 100 * R.slope / gain.value  # in %, as every surface states it
            qe = Estimate(qv, qv * math.hypot(R.slope_se / R.slope, gain.se / gain.value), "%", "R/K (EMVA 1288 Eq. 52)")
        else:
            qe = Estimate.na(f"the signal does not rise with the photon counts (responsivity {R.slope:.3g} DN/photon)", "%")
    else:
        qe = Estimate.na("photon counts not given", "%")

    sens = sensitivity_threshold(rn_dn, gain)
    sat = fw["saturation_capacity"]
    if sat.available and sens.available and not sens.bound:
        dr = sat.value / sens.value
        dr_se = dr * math.hypot(sat.se / sat.value, (sens.se if math.isfinite(sens.se) else 0) / sens.value)
        drn = Estimate(dr, dr_se, "", "saturation capacity / absolute sensitivity threshold (EMVA 1288 4.0 Eq. 28)")
        drdb = Estimate(20 * math.log10(dr), 20 / math.log(10) * dr_se / dr, "dB", drn.note)
    elif sat.available and sens.available:
        dr = sat.value / sens.value
        drn = Estimate.limit(dr, "lower", "", "saturation capacity / sensitivity threshold (an upper limit)")
        drdb = Estimate.limit(20 * math.log10(dr), "lower", "dB", drn.note)
    else:
        why = sat.note if not sat.available else sens.note
        drn, drdb = Estimate.na(why), Estimate.na(why, "dB")

    # linearity error (5-95 % of saturation, line of S vs photons or exposure)
    le = Estimate.na("needs exposure or photon count per level", "%")
    if xlin is not None and not br.reached:
        le = Estimate.na(br.reason, "%")
    elif xlin is not None:
        xs = np.asarray(xlin, float)
        sel = [lv for lv in good if 0.05 * br.low_dn <= lv.signal <= 0.95 * br.low_dn]
        if len(sel) >= 3:
            x = xs[[lv.index for lv in sel]]
            y = np.array([lv.signal for lv in sel])
            le_v, le_se, dev = max_relative_deviation(x, y, [lv.signal_se for lv in sel])
            src = "the frame means' scatter" if signal_se is not None else "temporal noise / sqrt(N)"
            note = (f"max |relative deviation| from a line fitted on 5-95 % of saturation (min {dev.min():.3g}, "
                    f"max {dev.max():.3g}); SE: each level's signal SE ({src}) through the fit, at the extreme level")
            if not math.isfinite(le_se):
                note += " (SE not available: the levels' pixel and frame counts or frame means are not given)"
            le = Estimate(le_v, le_se, "%", note)
            if math.isfinite(le_se) and le_se > le_v:  # within the noise: how linear the data show it to be
                le = Estimate.limit(le_v + LIMIT_NSIGMA * le_se, "upper", "%", f"{le_v:.3g} ± {le_se:.2g} %, within "
                                    f"the levels' noise: below the value + {LIMIT_NSIGMA:g} SE; {note}")  # (one rule)
        else:
            le = Estimate.na(f"{len(sel)} levels within 5-95 % of saturation (needs 3)", "%")

    snr = {
        "signal_dn": np.array([lv.signal for lv in good]),
        "snr": np.array([lv.signal / math.sqrt(lv.total_var) for lv in good]),
        # SE of signal / sqrt(variance) from the variance's chi-square scatter: SNR sqrt(1 / (2 dof))
        "snr_se": np.array([lv.signal / math.sqrt(lv.total_var) * math.sqrt(0.5 / lv.dof) if lv.dof > 0
                            else math.nan for lv in good]),
        "signal_e": np.array([lv.signal / gain.value for lv in good]) if gain.available else np.array([]),
    }
    nm, zones = noise_model(good, dark, gain)
    to_dn, to_e, to_defs = _turnoffs(levels, br, gain, clip_limit)
    s_sat = max((lv.signal for lv in good), default=math.nan)  # the last level on the curve
    lin_text = local_slope_check_text([lv.signal for lv in good], [lv.variance for lv in good], k_wls.value, s_sat)
    from ares.analysis.ptc import sanity

    return sanity.apply(PtcResult(levels, gain, e_per_dn, cg, k_org, k_ast, gm.astier, gvr, rn_dn, rn_e, upper, sat_i,
                                  fw, drn, drdb, sens, qe, le, snr, nm, zones, br, head, gm, lin, k_wls, to_dn, to_e,
                                  to_defs, lin_text, de))
