"""Photon transfer: conversion gain, read noise, full well, DR, SNR, linearity, zones.

Input: one ``LevelStats`` per bright level and the dark ``LevelStats`` at the same
exposure (``ares.analysis.levels``). Signal ``S = mu_y - mu_dark`` and temporal variance
``V = s2_y - s2_dark`` (SCIENCE.md "Photon transfer"). Every level gets a status:

- ``"fit"``: used by the gain fits (at most ``fit_fraction`` of saturation);
- ``"valid"``: good data above the fit range (used for full well, SNR, zones);
- ``"excluded"``: clipped, non-monotonic, no signal or beyond saturation -- with the
  reason stated; excluded levels are never fitted.

Definitions (all labelled in the result): ``K`` in DN/e- (EMVA), its inverse in e-/DN,
conversion gain in uV/e- = K * LSB_uV / analog gain. Read noise
``sqrt(sigma_y.dark^2 - 1/12)/K`` (EMVA 1288); below 0.24 DN^2 only an upper limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ares.analysis.estimate import Estimate
from ares.analysis.levels import LevelStats
from ares.analysis.ptc_fit import AstierFit, LineFit, astier_fit, line_fit, origin_fit, wls_line
from ares.analysis.saturation import (index_linearity_turnoff, index_max_code, index_max_variance,
                                      index_ptc_turnoff)

QUANT_VAR = 1.0 / 12.0  # DN^2, uniform quantization noise
QUANT_LIMIT = 0.24  # DN^2, EMVA 1288: below this the dark noise is quantization-dominated


@dataclass(frozen=True)
class PtcLevel:
    index: int  # position in the input
    signal: float  # DN, dark subtracted
    variance: float  # DN^2, dark subtracted
    variance_se: float
    dof: float
    total_var: float  # DN^2, bright temporal variance (dark not subtracted), for SNR
    spatial_var: float  # DN^2, spatial variance of the level (temporal part removed)
    frac_at_max: float
    exposure_s: float = math.nan
    photons: float = math.nan
    status: str = "fit"  # "fit" | "valid" | "excluded"
    reason: str = ""


@dataclass
class PtcResult:
    levels: list[PtcLevel]
    gain_dn_per_e: Estimate  # WLS line (ARES primary)
    gain_e_per_dn: Estimate
    conversion_gain_uv_per_e: Estimate
    gain_origin_dn_per_e: Estimate  # EMVA 1288 origin fit
    gain_astier_dn_per_e: Estimate
    astier: AstierFit | None
    gain_vs_range: dict[str, Estimate]
    read_noise_dn: Estimate
    read_noise_e: Estimate
    read_noise_is_upper_limit: bool
    saturation_index: int  # EMVA 3.0: max temporal variance
    full_well_e: dict[str, Estimate]
    dynamic_range: Estimate
    dynamic_range_db: Estimate
    sensitivity_threshold_e: Estimate
    qe: Estimate
    linearity_error_pct: Estimate
    snr: dict[str, np.ndarray]
    noise_model: dict[str, Estimate] = field(default_factory=dict)
    zones: dict[str, Estimate] = field(default_factory=dict)

    def used(self, status: str = "fit") -> list[PtcLevel]:
        return [lv for lv in self.levels if lv.status == status]

    def excluded(self) -> list[tuple[int, str]]:
        return [(lv.index, lv.reason) for lv in self.levels if lv.status == "excluded"]


def _inv(e: Estimate, unit: str, note: str = "") -> Estimate:
    if not e.available or e.value == 0:
        return Estimate.na("gain not available", unit)
    return Estimate(1.0 / e.value, e.se / e.value**2, unit, note)


def read_noise(dark: Sequence[LevelStats], exposure_s: Sequence[float] | None,
               gain: Estimate) -> tuple[Estimate, Estimate, bool]:
    """sigma_y.dark (DN, intercept at t=0 when >= 3 exposures) and read noise in e-."""
    # the same dark level may serve several bright levels: count each once
    seen: dict[int, int] = {}
    for i, d in enumerate(dark):
        seen.setdefault(id(d), i)
    keep = sorted(seen.values())
    dark = [dark[i] for i in keep]
    v = np.array([d.var for d in dark], float)
    se = np.array([d.var_se for d in dark], float)
    t = None if exposure_s is None else np.asarray(exposure_s, float)[keep]
    if t is not None and np.unique(t).size >= 3:
        lf = line_fit(t, v)
        s2, s2_se, how = lf.intercept, lf.intercept_se, "intercept of dark variance vs exposure"
    else:
        w = 1.0 / se**2
        s2 = float(np.sum(w * v) / np.sum(w))
        s2_se = float(math.sqrt(1.0 / np.sum(w)))
        if v.size > 1:
            s2_se = max(s2_se, float(np.std(v, ddof=1) / math.sqrt(v.size)))
        how = "mean dark temporal variance"
    upper = s2 < QUANT_LIMIT
    if upper:
        s2_used = QUANT_LIMIT
        note = f"upper limit: sigma_y.dark^2 = {s2:.3g} DN^2 < 0.24 DN^2 (quantization dominates)"
        dn = Estimate(math.sqrt(QUANT_LIMIT), math.nan, "DN", note)
    else:
        s2_used = s2
        dn = Estimate(math.sqrt(s2), s2_se / (2 * math.sqrt(s2)), "DN", how)
    if not gain.available:
        return dn, Estimate.na("gain not available", "e-"), upper
    num = math.sqrt(max(s2_used - QUANT_VAR, 0.0))
    val = num / gain.value
    if upper:
        return dn, Estimate(val, math.nan, "e-", dn.note), True
    d_s2 = s2_se / (2 * num) / gain.value if num > 0 else math.nan
    se_e = math.hypot(d_s2, val * gain.se / gain.value)
    return dn, Estimate(val, se_e, "e-", "sqrt(sigma_y.dark^2 - 1/12)/K; " + how), False


def classify_levels(bright: Sequence[LevelStats], dark: Sequence[LevelStats],
                    exposure_s=None, photons=None, clip_limit: float = 0.002,
                    fit_fraction: float = 0.7, offset_correction_note: str = "") -> tuple[list[PtcLevel], int]:
    n = len(bright)
    S = np.array([b.mean - d.mean for b, d in zip(bright, dark)])
    V = np.array([b.var - d.var for b, d in zip(bright, dark)])
    dof = np.array([min(b.dof, d.dof) for b, d in zip(bright, dark)], float)
    Vse = np.sqrt(np.array([b.var_se**2 + d.var_se**2 for b, d in zip(bright, dark)]))
    t = np.full(n, math.nan) if exposure_s is None else np.asarray(exposure_s, float)
    p = np.full(n, math.nan) if photons is None else np.asarray(photons, float)
    status = ["fit"] * n
    reason = [""] * n
    # nominal order: photons, then exposure, then input order
    if photons is not None and np.all(np.isfinite(p)):
        nominal = p.copy()  # photons per pixel already include the exposure time
    elif exposure_s is not None and np.all(np.isfinite(t)):
        nominal = t.copy()
    else:
        nominal = np.arange(n, dtype=float)
    order = np.argsort(nominal, kind="stable")
    for i in range(n):
        b = bright[i]
        if b.frac_at_max > clip_limit:
            status[i], reason[i] = "excluded", (
                f"clipped: {100 * b.frac_at_max:.3g} % of samples at the maximum code (limit {100 * clip_limit:g} %)")
        elif b.frac_at_min > clip_limit:
            status[i], reason[i] = "excluded", f"clipped: {100 * b.frac_at_min:.3g} % of samples at code 0"
        elif not S[i] > 0 or not V[i] > 0:
            status[i], reason[i] = "excluded", (
                f"no signal above dark (S = {S[i]:.4g} DN)" if not S[i] > 0 else
                f"no temporal variance above dark (V = {V[i]:.3g} DN^2): fully saturated or stuck")
    # non-monotonic: signal must rise with the nominal illumination
    best, best_i = -math.inf, -1
    for i in order:
        if status[i] == "excluded":
            continue
        if S[i] <= best and nominal[i] > nominal[best_i]:
            status[i], reason[i] = "excluded", (
                f"non-monotonic: signal {S[i]:.5g} DN not above {best:.5g} DN of level {best_i} "
                "at lower illumination")
            continue
        if S[i] > best:
            best, best_i = S[i], i
    ok = [i for i in order if status[i] != "excluded"]
    sat = -1
    if ok:
        sat_local = index_max_variance(V[ok])
        sat = ok[sat_local]
        for i in ok[sat_local + 1:]:
            status[i], reason[i] = "excluded", (
                f"beyond saturation: temporal variance peaks at level {sat} (EMVA 1288 3.0)")
        for i in ok[: sat_local + 1]:
            if S[i] > fit_fraction * S[sat]:
                status[i], reason[i] = "valid", f"above {100 * fit_fraction:g} % of saturation: not fitted"
    levels = [PtcLevel(i, float(S[i]), float(V[i]), float(Vse[i]), float(dof[i]), float(bright[i].var),
                       float(bright[i].spatial_var), float(bright[i].frac_at_max), float(t[i]), float(p[i]),
                       status[i], reason[i]) for i in range(n)]
    return levels, sat


def analyze_ptc(bright: Sequence[LevelStats], dark: Sequence[LevelStats], *, exposure_s=None,
                photons=None, clip_limit: float = 0.002, fit_fraction: float = 0.7,
                adc_lsb_uv: float | None = None, analog_gain: float = 1.0,
                dark_exposure_s=None, read_dark: Sequence[LevelStats] | None = None,
                signal_se=None) -> PtcResult:
    """Full photon-transfer analysis. ``dark[i]`` is the dark level at ``bright[i]``'s
    exposure. ``read_dark``/``dark_exposure_s`` (default: ``dark``/``exposure_s``) give
    the dark levels for sigma_y.dark.

    ``signal_se[i]`` (DN, optional): standard error of level i's signal not shared by all
    levels -- e.g. from the scatter of the bright stack's frame means (a frame-global
    offset moves the mean but is removed from the variance). The gain fit then weights by
    the effective variance ``se(V)^2 + (K se(S))^2``: a level's signal error matters at
    low signal, where ``V/S`` is most sensitive to it. Without it the weights are
    ``1/se(V)^2`` with ``se(V)`` of the dark-subtracted variance (bright and dark parts)."""
    if len(bright) != len(dark):
        raise ValueError("one dark level per bright level is required")
    levels, sat = classify_levels(bright, dark, exposure_s, photons, clip_limit, fit_fraction)
    fit = [lv for lv in levels if lv.status == "fit"]
    good = [lv for lv in levels if lv.status in ("fit", "valid")]
    S = np.array([lv.signal for lv in fit])
    V = np.array([lv.variance for lv in fit])
    N = np.array([lv.dof for lv in fit])

    def est_k(lf: LineFit, note: str) -> Estimate:
        if not math.isfinite(lf.slope):
            return Estimate.na(f"too few levels to fit ({lf.n})", "DN/e-")
        return Estimate(lf.slope, lf.slope_se, "DN/e-", note)

    Vse = np.array([lv.variance_se for lv in fit])
    lf = wls_line(S, V, N, v_se=Vse)
    how = "w = 1/se(V)^2"
    if signal_se is not None and math.isfinite(lf.slope):
        sse = np.array([signal_se[lv.index] for lv in fit], float)
        sse = np.where(np.isfinite(sse), sse, 0.0)
        for _ in range(2):  # effective variance: K from the previous pass
            lf = wls_line(S, V, N, v_se=np.hypot(Vse, lf.slope * sse))
        how = "w = 1/(se(V)^2 + K^2 se(S)^2)"
    k_wls = est_k(lf, f"WLS line of V vs S, {how}, up to {100 * fit_fraction:g} % of saturation")
    k_org = est_k(origin_fit(S, V, [lv.variance_se for lv in fit]),
                  f"EMVA 1288 origin fit up to {100 * fit_fraction:g} % of saturation")
    ast = astier_fit(S, V, N) if S.size >= 4 else None
    if ast is not None and math.isfinite(ast.gain_e_per_dn) and ast.gain_e_per_dn > 0:
        k_ast = Estimate(1 / ast.gain_e_per_dn, ast.gain_se / ast.gain_e_per_dn**2, "DN/e-",
                         f"Astier 2019 exponential, a00 = {ast.a00:.3g} 1/e-")
    else:
        k_ast = Estimate.na("Astier fit needs >= 4 levels", "DN/e-")
    gain = k_wls
    e_per_dn = _inv(gain, "e-/DN", "1/K")
    if adc_lsb_uv is not None and gain.available:
        cg = Estimate(gain.value * adc_lsb_uv / analog_gain, gain.se * adc_lsb_uv / analog_gain, "uV/e-",
                      f"K * {adc_lsb_uv:g} uV/DN / analog gain {analog_gain:g}")
    else:
        cg = Estimate.na("ADC LSB (uV) not given", "uV/e-")

    # gain against fit range (diagnostic)
    gvr: dict[str, Estimate] = {}
    if sat >= 0:
        s_sat = levels[sat].signal
        for f in (0.3, 0.5, 0.7):
            sel = [lv for lv in good if lv.signal <= f * s_sat]
            gvr[f"0-{int(f * 100)}%"] = est_k(origin_fit([lv.signal for lv in sel], [lv.variance for lv in sel],
                                                         [lv.variance_se for lv in sel]),
                                              f"origin fit 0-{int(f * 100)} % of saturation")

    rd = list(read_dark) if read_dark is not None else list(dark)
    rt = dark_exposure_s if read_dark is not None else exposure_s
    rn_dn, rn_e, upper = read_noise(rd, rt, gain)

    # full well, four labelled definitions
    fw: dict[str, Estimate] = {}
    allS = np.array([lv.signal for lv in levels])

    def fw_est(i: int, note: str) -> Estimate:
        if i < 0 or not gain.available:
            return Estimate.na("not reached in the data", "e-")
        v = levels[i].signal / gain.value
        return Estimate(v, v * gain.se / gain.value, "e-", note)

    fw["max_variance"] = fw_est(sat, "EMVA 1288 3.0: signal at the level of maximum temporal variance")
    order = np.argsort(allS)
    frac = np.array([levels[i].frac_at_max for i in order])
    if not np.any(frac > 0):
        fw["max_code"] = Estimate.na("no level reaches the ADC maximum code (see 'plateau')", "e-")
    else:
        im = index_max_code(frac, clip_limit)
        fw["max_code"] = fw_est(int(order[im]) if im >= 0 else -1,
                                f"EMVA 1288 4.0: highest level with <= {100 * clip_limit:g} % of pixels at max code")
    fw["plateau"] = _plateau(levels, gain, sat)
    cand = [lv for lv in levels if lv.signal > 0 and lv.variance > 0
            and not lv.reason.startswith(("non-monotonic", "clipped"))]
    if len(cand) >= 4:
        it, _keep = index_ptc_turnoff([lv.signal for lv in cand], [lv.variance for lv in cand],
                                      [lv.dof for lv in cand])
        fw["ptc_turnoff"] = fw_est(cand[it].index if it >= 0 else -1,
                                   "PTC turnoff: iterative 5-sigma rejection, gap rule relative to spacing")
    else:
        fw["ptc_turnoff"] = Estimate.na("fewer than 4 usable levels", "e-")
    xlin = photons if photons is not None else exposure_s
    if xlin is not None:
        xs = np.asarray(xlin, float)
        il = index_linearity_turnoff(xs[[lv.index for lv in cand]], [lv.signal for lv in cand])
        fw["linearity_1pct"] = fw_est(cand[il].index if il >= 0 else -1,
                                      "last level within 1 % of a line of signal vs "
                                      + ("photons" if photons is not None else "exposure"))
    else:
        fw["linearity_1pct"] = Estimate.na("needs exposure or photon count per level", "e-")

    # QE (responsivity R = slope of S vs photons, origin fit, over the fit range) / K
    if photons is not None and gain.available and fit:
        R = origin_fit([lv.photons for lv in fit], [lv.signal for lv in fit])
        qv = R.slope / gain.value
        qe = Estimate(qv, qv * math.hypot(R.slope_se / R.slope, gain.se / gain.value), "", "R/K")
    else:
        qe = Estimate.na("photon counts not given", "")

    # sensitivity threshold (SNR = 1): mu_e.min = (1 + sqrt(1 + 4 sigma_d^2)) / 2  (EMVA 4.0)
    if rn_e.available:
        sd = rn_e.value
        thr = (1 + math.sqrt(1 + 4 * sd * sd)) / 2
        dthr = (2 * sd / math.sqrt(1 + 4 * sd * sd)) * (rn_e.se if math.isfinite(rn_e.se) else 0)
        sens = Estimate(thr, dthr if dthr else math.nan, "e-", "SNR = 1 (EMVA 1288 4.0)")
    else:
        sens = Estimate.na("read noise not available", "e-")
    fwv = fw["max_variance"]
    if fwv.available and rn_e.available and rn_e.value > 0:
        dr = fwv.value / rn_e.value
        dr_se = dr * math.hypot(fwv.se / fwv.value, (rn_e.se if math.isfinite(rn_e.se) else 0) / rn_e.value)
        drn = Estimate(dr, dr_se, "", "full well (max variance) / read noise")
        drdb = Estimate(20 * math.log10(dr), 20 / math.log(10) * dr_se / dr, "dB", drn.note)
    else:
        drn = Estimate.na("needs full well and read noise")
        drdb = Estimate.na("needs full well and read noise", "dB")

    # linearity error (5-95 % of saturation, line of S vs photons or exposure)
    le = Estimate.na("needs exposure or photon count per level", "%")
    if xlin is not None and sat >= 0:
        xs = np.asarray(xlin, float)
        s_sat = levels[sat].signal
        sel = [lv for lv in good if 0.05 * s_sat <= lv.signal <= 0.95 * s_sat]
        if len(sel) >= 3:
            x = xs[[lv.index for lv in sel]]
            y = np.array([lv.signal for lv in sel])
            a, b = np.polyfit(x, y, 1, w=1.0 / y)  # minimises relative deviations (as EMVA 1288)
            dev = 100 * (y - (a * x + b)) / (a * x + b)
            le = Estimate(float(np.max(np.abs(dev))), math.nan, "%",
                          f"max |relative deviation| from a line fitted on 5-95 % of saturation "
                          f"(min {dev.min():.3g}, max {dev.max():.3g})")

    snr = {
        "signal_dn": np.array([lv.signal for lv in good]),
        "snr": np.array([lv.signal / math.sqrt(lv.total_var) for lv in good]),
        "signal_e": np.array([lv.signal / gain.value for lv in good]) if gain.available else np.array([]),
    }
    nm, zones = noise_model(good, dark, gain)
    return PtcResult(levels, gain, e_per_dn, cg, k_org, k_ast, ast, gvr, rn_dn, rn_e, upper, sat, fw, drn,
                     drdb, sens, qe, le, snr, nm, zones)


def _plateau(levels: Sequence[PtcLevel], gain: Estimate, sat: int) -> Estimate:
    """Full well from the saturated plateau: the dark-subtracted signal of the levels
    above saturation whose temporal variance has collapsed (every pixel clipped at its
    full-well charge) -- the charge capacity itself, not the variance peak below it."""
    if sat < 0 or not gain.available:
        return Estimate.na("no saturation in the data", "e-")
    vpk = levels[sat].variance
    top = [lv for lv in levels if lv.signal > levels[sat].signal and lv.variance < 0.1 * vpk
           and not lv.reason.startswith("non-monotonic")]
    if not top:
        return Estimate.na("no level beyond saturation with collapsed variance (all pixels clipped)", "e-")
    smax = max(lv.signal for lv in top)
    top = [lv for lv in top if lv.signal >= 0.995 * smax]
    if np.median([lv.frac_at_max for lv in top]) > 0.5:
        return Estimate.na("the plateau is at the ADC maximum code: ADC-limited, not the pixel full well", "e-")
    sv = np.array([lv.signal for lv in top])
    v = float(np.median(sv)) / gain.value
    spread = float(np.std(sv, ddof=1) / math.sqrt(sv.size)) / gain.value if sv.size > 1 else 0.0
    return Estimate(v, math.hypot(spread, v * gain.se / gain.value), "e-",
                    f"saturated plateau: median signal of {sv.size} fully clipped level(s) / K")


def noise_model(good: Sequence[PtcLevel], dark: Sequence[LevelStats], gain: Estimate):
    """Fit sigma_total^2 = sigma_sensor^2 + N_e + (PRNU * N_e)^2 (all in e-), where
    sigma_total^2 = bright temporal + spatial variance. Returns (fit, zones)."""
    if not gain.available or len(good) < 3:
        return {}, {}
    k = gain.value
    rows = [(lv.signal / k, (lv.total_var + lv.spatial_var) / k**2) for lv in good
            if math.isfinite(lv.spatial_var)]
    if len(rows) < 3:
        return {}, {}
    ne, tot = np.array(rows).T
    y = tot - ne
    A = np.vstack([np.ones_like(ne), ne**2]).T
    # weights: relative error of a variance ~ sqrt(2/N); use 1/tot
    w = 1.0 / tot
    coef, *_ = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)
    r = (y - A @ coef) * w
    dof = max(len(y) - 2, 1)
    cov = np.linalg.inv((A * w[:, None]).T @ (A * w[:, None])) * float(r @ r) / dof
    se = np.sqrt(np.diag(cov))
    s2r, p2 = coef
    out = {}
    if s2r > 0:
        out["sensor_noise_e"] = Estimate(math.sqrt(s2r), se[0] / (2 * math.sqrt(s2r)), "e-",
                                         "dark temporal + DSNU, from the total-noise model")
    else:
        out["sensor_noise_e"] = Estimate.na("fitted sensor variance <= 0", "e-")
    if p2 > 0:
        out["prnu_pct"] = Estimate(100 * math.sqrt(p2), 100 * se[1] / (2 * math.sqrt(p2)), "%",
                                   "total-noise model; includes illumination non-uniformity (no high-pass)")
    else:
        out["prnu_pct"] = Estimate.na("fitted PRNU^2 <= 0", "%")
    zones = {}
    if out["sensor_noise_e"].available:
        zones["read_to_shot_e"] = Estimate(s2r, se[0], "e-", "N_e where shot noise equals the sensor noise")
    if out["prnu_pct"].available:
        zones["shot_to_prnu_e"] = Estimate(1 / p2, se[1] / p2**2, "e-", "N_e where PRNU noise equals shot noise")
    return out, zones


def loglog_slopes(signal, noise) -> np.ndarray:
    """Local slopes of log(noise) vs log(signal): ~0 read floor, 1/2 shot, 1 PRNU."""
    s = np.asarray(signal, float)
    n = np.asarray(noise, float)
    ok = (s > 0) & (n > 0)
    return np.gradient(np.log(n[ok]), np.log(s[ok])) if ok.sum() >= 2 else np.array([])
