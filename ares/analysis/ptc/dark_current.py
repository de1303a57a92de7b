"""Dark current and dark non-uniformity against exposure time and temperature.

- ``dark_current``: slope of the dark mean vs exposure (>= 6 exposures) in DN/s, / K
  -> e-/s; cross-check: slope of the dark temporal variance vs exposure / K^2 (dark
  shot noise: the variance in e-^2 grows like the mean in e-). Given each level's frame
  means (ARES's estimator on a recorded run), the slope's SE is decided on the stacks'
  measured frame-to-frame scatter and checked against the levels' residuals about the
  line (``_mean_slope``); without them (EMVA 1288 4.0 Section 7.1 as written: a table)
  it is the regression's one-sigma error.
- ``dsnu_vs_exposure``: ``sigma_spatial^2 = A^2 + t^2 DSNU^2`` (seed 001, "Dark noise as
  f(exposure time)"), linear in (A^2, DSNU^2).
- ``doubling_temperature``: ``X_T = X_60 * 2^((T - 60)/Td)`` fitted as a line of
  ``log2 X`` vs ``T`` (seed 001, "Dark noise as f(temperature)").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.median import n_distinct
from ares.analysis.stats.physical import in_range, resolved
from ares.analysis.ptc.dark_drift import CLOCK_R2, DriftFit, drift_fit
from ares.analysis.ptc.fit import line_fit, residual_se_widening, wls_line

MIN_EXPOSURES = 6
QUANT_SIGMA_DN = 0.24  # EMVA 1288 4.0 Linear Section 6.6: below it the dark noise is quantization noise


@dataclass(frozen=True)
class DarkCurrent:
    rate_dn_per_s: Estimate
    rate_e_per_s: Estimate
    rate_from_variance_e_per_s: Estimate
    offset_dn: Estimate  # dark mean at t = 0
    drift: DriftFit | None = None  # the offset's drift on the bench's clock, where the frames were timed (dark_drift)


def _div(e: Estimate, k: Estimate | float, unit: str, note: str) -> Estimate:
    kv = k.value if isinstance(k, Estimate) else float(k)
    kse = k.se if isinstance(k, Estimate) and math.isfinite(k.se) else 0.0
    if not e.available or not math.isfinite(kv) or kv == 0:
        return Estimate.na("gain not available" if e.available else e.note, unit)
    v = e.value / kv
    if e.bound:  # a limit stays a limit (K's own SE is small beside the 3 SE that made it)
        return Estimate.limit(v, e.bound, unit, f"{note}: {e.note}")
    return Estimate(v, math.hypot(e.se / kv, v * kse / kv), unit, note)


DRIFT_P = 0.01  # the levels scatter about the line more than their frames do, at this F-test probability


def _pooled_frame_scatter(frame_means) -> tuple[float, int]:
    """(variance of one frame's mean about its stack's mean, pooled over the levels, DN^2;
    its degrees of freedom) from each level's frame means."""
    ss, dof = 0.0, 0
    for fm in frame_means:
        x = np.asarray(fm if fm is not None else [], float)
        x = x[np.isfinite(x)]
        if x.size >= 2:
            ss += float(np.sum((x - x.mean()) ** 2))
            dof += x.size - 1
    return (ss / dof if dof else math.nan), dof


def _mean_slope(t, m, frame_means) -> tuple[float, float, float, float, str]:
    """(slope DN/s, its SE, intercept DN, its SE, how the SEs were decided) of the dark mean against
    exposure, on the measured scatter (issue 48: decisions on the data's own scatter).

    Each level's mean is uncertain by the frame-to-frame scatter of its stack's frame means
    (the frame-global offset, flicker, clamp noise), pooled over the levels, / sqrt(frames):
    the weights and the SE, which carries Student's t for the pooled degrees of freedom (so
    3 SE cover what they claim). Where the levels scatter about the line significantly more
    than their frames do (F-test p < ``DRIFT_P``: an offset or temperature drifting between
    stages), the measured residuals win: the SE is the residuals' with Student's t for n - 2
    degrees of freedom, and the note says so. Without frame means the SE is the residuals'
    with Student's t. (The residuals of 8 levels alone gave a 2-frame dark current 7 SE off
    its truth on the simulator, "ok", where the frames scatter 4x more than those residuals.)"""
    n = t.size
    s2, dof_f = _pooled_frame_scatter(frame_means) if frame_means is not None else (math.nan, 0)
    nf = np.array([max(int(np.isfinite(np.asarray(fm if fm is not None else [], float)).sum()), 1)
                   for fm in frame_means], float) if frame_means is not None else np.ones(n)
    if not (dof_f >= 1 and s2 > 0):
        lf = line_fit(t, m)
        w = residual_se_widening(n - 2)
        return lf.slope, lf.slope_se * w, lf.intercept, lf.intercept_se * w, (
            f"SE from the {n} levels' residuals about the line x Student's t ({n - 2} dof: x {w:.3g})")
    sig = np.sqrt(s2 / nf)
    lf = wls_line(t, m, nf, v_se=sig)
    r = (m - (lf.slope * t + lf.intercept)) / sig
    chi2 = float(r @ r) / max(n - 2, 1)
    undo = 1.0 / math.sqrt(max(lf.chi2_red, 1.0))  # (wls_line scales its SEs by chi2 > 1: undone here)
    se_f, ise_f = lf.slope_se * undo, lf.intercept_se * undo
    from ares.analysis.stats.tails import f_sf

    p = f_sf(n - 2, dof_f, chi2) if chi2 > 1 and n > 2 else 1.0
    if p < DRIFT_P:
        w = residual_se_widening(n - 2)
        return lf.slope, se_f * math.sqrt(chi2) * w, lf.intercept, ise_f * math.sqrt(chi2) * w, (
            f"the levels scatter about the line {math.sqrt(chi2):.2g}x more than their frames do (F-test p "
            f"{p:.2g}: an offset or temperature drifting between stages); SE from the residuals x Student's t "
            f"({n - 2} dof: x {w:.3g})")
    w = residual_se_widening(dof_f)
    return lf.slope, se_f * w, lf.intercept, ise_f * w, (
        f"SE from the stacks' frame-to-frame scatter ({math.sqrt(s2):.2g} DN a frame, {dof_f} dof, x Student's t "
        f"{w:.3g}); the levels' residuals agree with it (chi2/dof {chi2:.2g})")


def dark_current(exposure_s, dark_mean_dn, gain_dn_per_e: Estimate | float, dark_var_dn2=None,
                 min_exposures: int = MIN_EXPOSURES, frame_means=None, frame_times=None) -> DarkCurrent:
    """``frame_means``: each level's frame means (DN), as a run records them: the SEs are
    then decided on the measured scatter (``_mean_slope``), the variance slope's SE carries
    Student's t; without them, EMVA 1288 4.0 Section 7.1 as written (the regression's
    one-sigma errors). ``frame_times``: with them, each frame's readout time on the bench's
    clock (s): the offset's drift is fitted beside the rate (``dark_drift.drift_fit``) and kept
    where the frames show it; ``DarkCurrent.drift`` says whether the order separated the two."""
    t = np.asarray(exposure_s, float)
    m = np.asarray(dark_mean_dn, float)
    distinct = n_distinct(t)
    if distinct < min_exposures:
        na = Estimate.na(f"needs >= {min_exposures} distinct exposure times, got {distinct}", "e-/s")
        return DarkCurrent(Estimate.na(na.note, "DN/s"), na, na, Estimate.na(na.note, "DN"))
    drift = drift_fit(t, frame_means, frame_times) if frame_means is not None and frame_times is not None else None
    if drift is not None and drift.kept:
        slope, slope_se, icpt, icpt_se = drift.slope, drift.slope_se, drift.intercept, drift.intercept_se
        how = "; " + drift.how
    elif frame_means is not None:
        slope, slope_se, icpt, icpt_se, how = _mean_slope(t, m, frame_means)
        how = "; " + how + (_no_drift(drift, slope_se) if drift is not None else "")
        if drift is not None and math.isfinite(drift.shift_per_drift):
            # a drift below the frames' detection limit still moves the slope by drift x shift (a test
            # passed is not a drift excluded): its measured uncertainty is in the SE -- nothing where the
            # order does not follow the clock (shift ~ 0), a drift-limited SE in increasing order
            slope_se = math.hypot(slope_se, drift.drift_se * drift.shift_per_drift)
    else:
        lf = line_fit(t, m)
        slope, slope_se, icpt, icpt_se, how = lf.slope, lf.slope_se, lf.intercept, lf.intercept_se, ""
    rate_dn = in_range(Estimate(slope, slope_se, "DN/s", "slope of dark mean vs exposure" + how), 0.0,
                       what="dark current")
    rate_e = in_range(_div(Estimate(slope, slope_se, "DN/s"), gain_dn_per_e, "e-/s",
                           "slope of dark mean vs exposure / K" + how), 0.0, what="dark current")
    k = gain_dn_per_e.value if isinstance(gain_dn_per_e, Estimate) else float(gain_dn_per_e)
    if dark_var_dn2 is not None and not (math.isfinite(k) and k > 0):
        rv = Estimate.na("gain not available", "e-/s")
    elif dark_var_dn2 is not None and np.nanmin(np.asarray(dark_var_dn2, float)) < QUANT_SIGMA_DN**2:
        rv = Estimate.na(f"the dark temporal noise ({math.sqrt(max(np.nanmin(dark_var_dn2), 0)):.3g} DN) is below "
                         f"{QUANT_SIGMA_DN} DN: dominated by quantization noise, its slope does not measure the "
                         "dark current (EMVA 1288 4.0 Linear Section 6.6)", "e-/s")
    elif dark_var_dn2 is not None:
        lv = line_fit(t, np.asarray(dark_var_dn2, float))
        kse = gain_dn_per_e.se if isinstance(gain_dn_per_e, Estimate) and math.isfinite(gain_dn_per_e.se) else 0.0
        v = lv.slope / k**2
        widen = residual_se_widening(t.size - 2) if frame_means is not None else 1.0  # (residual SE: t, as above)
        se = math.hypot(widen * lv.slope_se / k**2, 2 * v * kse / k)
        rv = Estimate(v, se, "e-/s", "slope of dark temporal variance vs exposure / K^2 (cross-check; EMVA 1288 "
                                     "4.0 Section 7.1)")
        # (a rise of the variance smaller than the quantization noise's 1/12 DN^2 is still measured:
        # quantization adds a constant to the variance, not a slope, once the noise dithers it --
        # the floor rule above; the text asks for the value with its error, Section 7.1)
        rv = in_range(rv, 0.0, what="dark current from the variance")
    else:
        rv = Estimate.na("dark variances not given", "e-/s")
    at = " at the sweep's mean time on the bench's clock (the offset drifts)" if drift is not None and drift.kept else ""
    return DarkCurrent(rate_dn, rate_e, rv, Estimate(icpt, icpt_se, "DN", "dark mean at t = 0" + at), drift)


def _no_drift(d: DriftFit, slope_se: float) -> str:
    """What the frames' times said where they show no drift, and what a drift they cannot exclude
    adds to the slope's SE (``slope_se``: the SE without it)."""
    s = f"; the frames show no drift ({d.drift:.2g} ± {d.drift_se:.2g} DN/s of clock, F-test p {d.p:.2g})"
    add = abs(d.drift_se * d.shift_per_drift) if math.isfinite(d.shift_per_drift) else 0.0
    if add > 0.1 * slope_se:
        s += (f"; a drift that small still moves the slope by {d.shift_per_drift:.3g} s per s of exposure"
              + (" (the exposures follow the clock)" if d.follows_clock >= CLOCK_R2 else "")
              + f": the SE holds its ± {add:.2g} DN/s (shuffle the exposures or bracket them with reference "
              "darks to shrink it)")
    return s


def with_upper_limit(key: str, e: Estimate) -> dict[str, Estimate]:
    """A dark current as EMVA 1288 4.0 Section 7.1 asks (Linear and General alike): the
    value with its one-sigma error from the regression, always; when it is not above that
    error, also the upper limit mu_I + sigma_I (provided it is > 0) as ``<key>_upper``."""
    out = {key: e}
    if e.available and e.value <= e.se and e.value + e.se > 0:
        out[key + "_upper"] = Estimate.limit(e.value + e.se, "upper", e.unit, "mu_I + sigma_I: the rate is not above "
                                                                           "its one-sigma error (Section 7.1)")
    return out


@dataclass(frozen=True)
class DsnuFit:
    a_dn: Estimate  # exposure-independent spatial sigma (offset FPN)
    dsnu_dn_per_s: Estimate
    dsnu_e_per_s: Estimate


def dsnu_vs_exposure(exposure_s, sigma_spatial_dn, gain_dn_per_e: Estimate | float | None = None) -> DsnuFit:
    """Fit ``sigma^2 = A^2 + t^2 DSNU^2`` (least squares on the variances)."""
    t = np.asarray(exposure_s, float)
    s2 = np.asarray(sigma_spatial_dn, float) ** 2
    if n_distinct(t) < 3:
        na = "needs >= 3 exposure times"
        return DsnuFit(Estimate.na(na, "DN"), Estimate.na(na, "DN/s"), Estimate.na(na, "e-/s"))
    A = np.vstack([np.ones_like(t), t**2]).T
    w = 1.0 / np.maximum(s2, 1e-12)  # relative errors of variances are ~ constant
    Aw = A * w[:, None]
    coef, *_ = np.linalg.lstsq(Aw, s2 * w, rcond=None)
    r = s2 * w - Aw @ coef
    dof = max(t.size - 2, 1)
    cov = np.linalg.inv(Aw.T @ Aw) * float(r @ r) / dof
    se = np.sqrt(np.diag(cov)) * residual_se_widening(dof)  # the residual scatter's: Student's t
    a2, d2 = coef

    def root(v, sev, unit, note):
        """The root of a fitted square; a square not resolved from 0 (SE above it) gives only the
        upper limit sqrt(square + 3 SE) (``physical.resolved``; issue 48: DSNU 0.16 ± 0.67 DN/s was "ok")."""
        sq = resolved(Estimate(v, sev, f"({unit})^2", note), f"the fitted square of the {note.split(':')[0]}",
                      side="upper")
        if sq.bound:
            return (Estimate.limit(math.sqrt(sq.value), "upper", unit, sq.note) if sq.value > 0 else
                    Estimate.na(f"fitted square {v:.3g} ± {sev:.2g} <= 0 even at 3 SE", unit))
        return Estimate(math.sqrt(v), sev / (2 * math.sqrt(v)), unit, note)

    a = root(a2, se[0], "DN", "offset FPN (t = 0)")
    d = root(d2, se[1], "DN/s", "DSNU: spatial sigma of the dark-current rate")
    de = _div(d, gain_dn_per_e, "e-/s", "DSNU / K") if gain_dn_per_e is not None else Estimate.na(
        "gain not given", "e-/s")
    return DsnuFit(a, d, de)


@dataclass(frozen=True)
class DoublingFit:
    doubling_c: Estimate  # Td
    value_at_ref: Estimate  # X at ref_c
    ref_c: float


def doubling_temperature(temperature_c, values, values_se=None, ref_c: float = 60.0) -> DoublingFit:
    """Fit ``log2 X = log2 X_ref + (T - ref)/Td`` (weighted when SEs are given)."""
    T = np.asarray(temperature_c, float)
    x = np.asarray(values, float)
    ok = x > 0
    if ok.sum() < 3:
        na = "needs >= 3 temperatures with a positive value"
        return DoublingFit(Estimate.na(na, "C"), Estimate.na(na), ref_c)
    T, x = T[ok], x[ok]
    y = np.log2(x)
    if values_se is not None:
        sy = np.asarray(values_se, float)[ok] / (x * math.log(2))
        w = 1.0 / np.maximum(sy, 1e-12)
    else:
        w = np.ones_like(y)
    A = np.vstack([T - ref_c, np.ones_like(T)]).T
    Aw = A * w[:, None]
    coef, *_ = np.linalg.lstsq(Aw, y * w, rcond=None)
    r = y * w - Aw @ coef
    dof = max(T.size - 2, 1)
    chi2 = float(r @ r) / dof
    scale = max(chi2, 1.0) if values_se is not None else chi2
    cov = np.linalg.inv(Aw.T @ Aw) * scale
    se = np.sqrt(np.diag(cov))
    slope, icpt = coef
    if slope <= 0:
        td = Estimate.na("value does not grow with temperature", "C")
    else:
        td = Estimate(1 / slope, se[0] / slope**2, "C", "log2 fit: X_T = X_ref * 2^((T - ref)/Td)")
    xr = 2.0**icpt
    return DoublingFit(td, Estimate(xr, xr * math.log(2) * se[1], "", f"value at {ref_c:g} C"), ref_c)
