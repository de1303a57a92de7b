"""The EMVA 1288 parameter set with the standard's own definitions (Release 3.0, as
used for the published results of the EMVA reference data sets).

Kept apart from ARES's own (unbiased, weighted) estimators in ``ptc.py``: these are
the numbers a data sheet quotes. Definitions (Release 3.0 and the EMVA reference
implementation; each verified on the reference CCD, see tests/test_emva_reference.py):

- temporal variance of a pair: ``mean((A-B)^2)/2`` -- no mean-difference term in 3.0
  (``offset_correction=True`` gives the Release 4.0 form);
- saturation: the level of maximum temporal variance, searched from the top;
- ``K``: unweighted origin fit of ``s2_y - s2_y.dark`` vs ``mu_y - mu_y.dark`` over the
  levels from the first up to the last with signal <= 70 % of the saturation signal;
- ``R`` (responsivity): the same origin fit of ``mu_y - mu_y.dark`` vs ``mu_p``;
  ``QE = R/K``;
- ``sigma_y.dark``: intercept at t = 0 of a line of ``s2_y.dark`` vs exposure (one
  exposure: its value); at least sqrt(0.24) DN;
- ``mu_e.sat = QE * mu_p.sat`` (photons at saturation times QE -- *not* the dark-
  subtracted signal over K, which is ~0.8 % lower on the reference CCD);
- ``SNR_max = sqrt(mu_e.sat)``; ``mu_p.min = (sigma_y.dark/K + 1/2)/QE``;
  ``DR = mu_p.sat/mu_p.min``;
- ``u_I_mean``: slope of ``mu_y.dark`` vs exposure / K (e-/s);
  ``u_I_var``: slope of ``s2_y.dark`` vs exposure / K^2 (Section 7.1);
- ``DSNU1288 = sqrt(s2_y.dark)/K`` with ``s2 = var(avg image, ddof=1) - mean(pixel
  temporal var)/L``; ``PRNU1288 = sqrt(s2_y - s2_y.dark)/(mu_y - mu_y.dark)`` in %, from
  the L-image stacks with no high-pass (Release 3.0);
- linearity: weighted fit between 5 % and 95 % of saturation minimising relative
  deviations; ``LE_min``/``LE_max`` the extreme relative deviations in %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ares.analysis.emva.gain_term import GainTerm, attribute, gain_term
from ares.analysis.emva.sanity import judge
from ares.analysis.stats.estimate import EXACT_PHOTONS, Estimate
from ares.analysis.ptc.levels import SpatialStats, pair_stats, spatial_stats
from ares.analysis.stats.median import n_distinct
from ares.analysis.spatial.nonuniformity import std_estimate
from ares.analysis.spatial.pattern_se import stack_variance_se
from ares.analysis.stats.physical import resolved, snr_db, snr_in_range
from ares.analysis.ptc.fit import line_fit, origin_fit
from ares.analysis.ptc.saturation import index_max_variance

S2Q = 1.0 / 12.0
ATTRIBUTION = "EMVA 1288 reference data set, (C) 2011 Basler AG, CC BY-SA 3.0"
REFERENCE_NAMES = ("K", "sigma_y_dark", "u_e_sat", "QE", "SNR_max", "DR", "u_I_mean",
                   "DSNU1288", "PRNU1288", "LE_min", "LE_max")


@dataclass(frozen=True)
class TemporalData:
    """Per bright level (sorted by exposure): exposure (s), photons, mean and variance of
    the bright pair and of the dark pair at the same exposure."""

    texp_s: np.ndarray
    u_p: np.ndarray
    u_y: np.ndarray
    s2_y: np.ndarray
    u_ydark: np.ndarray
    s2_ydark: np.ndarray
    n_pixels: int = 0


def temporal_from_pairs(bright_pairs: Sequence[np.ndarray], dark_pairs: Sequence[np.ndarray],
                        texp_s: Sequence[float], photons: Sequence[float],
                        offset_correction: bool = False) -> TemporalData:
    """Build the temporal data from (2, rows, cols) pairs; Release 3.0 variance by default."""
    b = [pair_stats(p[0], p[1], offset_correction=offset_correction) for p in bright_pairs]
    d = [pair_stats(p[0], p[1], offset_correction=offset_correction) for p in dark_pairs]
    t = np.asarray(texp_s, float)
    order = np.argsort(t, kind="stable")

    def arr(xs):
        return np.asarray(xs, float)[order]

    return TemporalData(t[order], arr(photons), arr([x.mean for x in b]), arr([x.var for x in b]),
                        arr([x.mean for x in d]), arr([x.var for x in d]), b[0].n_pixels if b else 0)


@dataclass
class Emva1288Result:
    values: dict[str, Estimate]
    index_u_ysat: int
    index_sensitivity_max: int
    linearity_deviation_pct: np.ndarray
    temporal: TemporalData
    extra: dict[str, Estimate]

    def to_json(self) -> dict:
        return {k: self.values[k].to_dict() for k in REFERENCE_NAMES if k in self.values}


def _line_b0(x, y):
    lf = origin_fit(x, y)
    return lf.slope, lf.slope_se


def emva1288_results(temporal: TemporalData, spatial_bright: SpatialStats | None = None,
                     spatial_dark: SpatialStats | None = None,
                     index_u_ysat: int | None = None) -> Emva1288Result:
    """The Release 3.0 set as the reference implementation computes it. Each figure whose
    preconditions fail (no two levels with signal up to 70 % of saturation, a gain or a
    responsivity that does not rise, photon counts all zero, no level in the linearity
    window) is "not available" with the reason, never a number from a failed fit. The
    figures in electrons and photons carry K's uncertainty as the zero-signal gain, as 4.0's
    (``gain_term``; the dark current keeps the regression's SE, as 4.0's Section 7.1 does);
    each widened figure's note says how much of its SE that is, K's note the comparison."""
    r, gt = _emva1288_results(temporal, spatial_bright, spatial_dark, index_u_ysat, True)
    if gt is not None and gt.widens:
        plain, _ = _emva1288_results(temporal, spatial_bright, spatial_dark, index_u_ysat, False)
        r.values = attribute(r.values, plain.values, gt)
        r.extra = attribute(r.extra, plain.extra, gt)
        k = r.values["K"]
        r.values["K"] = Estimate(k.value, k.se, k.unit, f"{k.note}; {gt.sentence}")
    return r


def _emva1288_results(temporal: TemporalData, spatial_bright: SpatialStats | None,
                      spatial_dark: SpatialStats | None, index_u_ysat: int | None,
                      with_gain_term: bool) -> tuple[Emva1288Result, "GainTerm | None"]:
    td = temporal
    Y = td.u_y - td.u_ydark
    V = td.s2_y - td.s2_ydark
    isat = index_u_ysat if index_u_ysat is not None else index_max_variance(td.s2_y)
    below = np.nonzero(Y <= 0.7 * Y[isat])[0]
    imax = int(below.max()) if below.size else -1
    vals: dict[str, Estimate] = {}
    extra: dict[str, Estimate] = {}
    na = Estimate.na
    K = R = K_se = math.nan
    if not (Y[isat] > 0 and imax >= 1):
        why_k = why_r = (f"no two levels with signal above dark up to 70 % of saturation (signal at saturation "
                         f"{Y[isat]:.3g} DN)")
    else:
        sl = slice(0, imax + 1)
        K, K_se = _line_b0(Y[sl], V[sl])
        R, R_se = _line_b0(td.u_p[sl], Y[sl])
        why_k = "" if K > 0 and math.isfinite(K_se) else f"the variance does not rise with the signal (K = {K:.3g})"
        why_r = ("" if R > 0 and math.isfinite(R_se) else
                 "the data set gives no photon counts (all 0)" if not np.any(td.u_p[sl] > 0) else
                 f"the signal does not rise with the photon counts (responsivity {R:.3g} DN/photon)")
    why_qe = why_k or why_r
    gt = None
    if not why_k:
        vals["K"] = Estimate(K, K_se, "DN/e-", "origin fit of s2_y-s2_y.dark vs mu_y-mu_y.dark up to 70 % sat")
        if with_gain_term and td.n_pixels:  # (each pair variance's SE: sqrt(2 / n) s2, n pixels)
            n = np.full(imax + 1, float(td.n_pixels))
            gt = gain_term(Y[sl], V[sl], np.sqrt(2.0 / n) * np.hypot(td.s2_y[sl], td.s2_ydark[sl]), n, vals["K"],
                           "the origin-fit K (Release 3.0)")
    else:
        vals["K"] = na(why_k, "DN/e-")
    K_se_e = gt.se if gt is not None else K_se  # K's SE in the figures in electrons and photons
    extra["R"] = Estimate(R, R_se, "DN/p", "responsivity, origin fit") if not why_r else na(why_r, "DN/p")
    if not why_qe:
        QE = R / K
        QE_se = QE * math.hypot(R_se / R, K_se_e / K)
        vals["QE"] = Estimate(100 * QE, 100 * QE_se, "%", "R/K")
    else:
        vals["QE"] = na(why_qe, "%")

    nexp = n_distinct(td.texp_s)
    if nexp <= 2:  # (its SE: a pair variance's own, sqrt(2 / dof) s2 with one dof a pixel -- ``LevelStats.var_se``)
        s2d = float(td.s2_ydark[0])
        s2d_se = math.sqrt(2.0 / td.n_pixels) * abs(s2d) if td.n_pixels else math.nan
    else:
        lf = line_fit(td.texp_s, td.s2_ydark)
        s2d, s2d_se = lf.intercept, lf.intercept_se
    note = "intercept of s2_y.dark vs exposure" if nexp > 2 else "the first dark pair's variance (one exposure time)"
    # below 0.24 DN^2 quantization dominates: the reference (and 4.0 Linear Eq. 54) uses 0.24, so
    # sigma_y.dark -- and every figure read off it -- is only a limit: sigma_y.dark, sigma_d,
    # mu_p.min, mu_e.min below theirs, DR above its value (never "ok" with the floor's SE)
    floored = not s2d >= 0.24
    if floored:
        why_floor = (f"sigma_y.dark^2 {s2d:.3g} DN^2 is below 0.24 DN^2: quantization dominates, the floor 0.24 DN^2 "
                     "is used (EMVA 1288 4.0 Linear Eq. 54)")
        s2d = 0.24
    syd = math.sqrt(s2d)
    vals["sigma_y_dark"] = (Estimate.limit(syd, "upper", "DN", why_floor) if floored else
                            Estimate(syd, s2d_se / (2 * syd), "DN", note))
    if not why_k:
        sigma_d = math.sqrt(s2d - S2Q) / K
        extra["sigma_d"] = (Estimate.limit(sigma_d, "upper", "e-", "sqrt(0.24 - 1/12)/K; " + why_floor) if floored
                            else Estimate(sigma_d, sigma_d * K_se_e / K, "e-", "sqrt(sigma_y.dark^2 - 1/12)/K"))
    else:
        extra["sigma_d"] = na(why_k, "e-")

    u_p_sat = float(td.u_p[isat])
    extra["u_p_sat"] = Estimate.declared(u_p_sat, "p", EXACT_PHOTONS,
                                         "photons at the maximum-variance level (the data set's photon count)")
    if not why_k and Y[isat] > 0:
        extra["u_e_sat_signal"] = Estimate(Y[isat] / K, Y[isat] / K * K_se_e / K, "e-",
                                           "(mu_y.sat - mu_y.dark)/K (alternative definition)")
    else:
        extra["u_e_sat_signal"] = na(why_k or "no signal at saturation", "e-")
    why_sat = why_qe or ("" if u_p_sat > 0 else "no photons at the saturation level")
    if not why_sat:
        u_e_sat = QE * u_p_sat
        vals["u_e_sat"] = Estimate(u_e_sat, u_e_sat * QE_se / QE, "e-", "QE * mu_p.sat (EMVA 1288 3.0)")
        # no sensor beats the photon shot noise: SNR_max <= sqrt(mu_p.sat) (a QE above 1 breaks it)
        vals["SNR_max"] = snr_in_range(Estimate(math.sqrt(u_e_sat), 0.5 * math.sqrt(u_e_sat) * QE_se / QE, "",
                                                "sqrt(mu_e.sat)"), u_p_sat, "SNR_max", "the photons at saturation")
        extra["SNR_max_dB"] = snr_db(vals["SNR_max"], "20 log10 SNR_max")
        u_p_min = (syd / K + 0.5) / QE  # = (sigma_y.dark + K/2) / R
        # SEs (issue 52): sigma_y.dark's, K's and R's, first order and independent; mu_p.sat is the
        # level's given photon count (no SE); sigma_y.dark's SE is 0 where two exposures cannot give it
        syd_se = vals["sigma_y_dark"].se if math.isfinite(vals["sigma_y_dark"].se) else 0.0
        p_se = math.hypot(syd_se / R, K_se_e / (2 * R), u_p_min * R_se / R)
        why_se = "" if math.isfinite(vals["sigma_y_dark"].se) else "; SE without sigma_y.dark's (not measured)"
        extra["u_p_min"] = Estimate(u_p_min, p_se, "p", "(sigma_y.dark/K + 1/2)/QE" + why_se)
        u_e_min = QE * u_p_min  # = sigma_y.dark/K + 1/2
        extra["u_e_min"] = Estimate(u_e_min, math.hypot(syd_se / K, syd / K * K_se_e / K), "e-", "QE * mu_p.min" + why_se)
        DR = u_p_sat / u_p_min
        DR_se = DR * p_se / u_p_min
        vals["DR"] = Estimate(DR, DR_se, "", "mu_p.sat / mu_p.min" + why_se)
        extra["DR_dB"] = Estimate(20 * math.log10(DR), 20 / math.log(10) * DR_se / DR, "dB", "20 log10 DR")
        if floored:  # (from sigma_y.dark's upper limit)
            for key, into, bound in (("u_p_min", extra, "upper"), ("u_e_min", extra, "upper"), ("DR", vals, "lower"),
                                     ("DR_dB", extra, "lower")):
                e = into[key]
                into[key] = Estimate.limit(e.value, bound, e.unit, f"{e.note}; from sigma_y.dark's upper limit")
    else:
        for key, unit, into in (("u_e_sat", "e-", vals), ("SNR_max", "", vals), ("SNR_max_dB", "dB", extra),
                                ("u_p_min", "p", extra), ("u_e_min", "e-", extra), ("DR", "", vals),
                                ("DR_dB", "dB", extra)):
            into[key] = na(why_sat, unit)

    if nexp <= 2:
        vals["u_I_mean"] = na("needs more than two exposure times", "e-/s")
    elif why_k:
        vals["u_I_mean"] = na(why_k, "e-/s")
        extra["u_I_var"] = na(why_k, "e-/s")
    else:
        lf = line_fit(td.texp_s, td.u_ydark)
        vals["u_I_mean"] = Estimate(lf.slope / K, math.hypot(lf.slope_se / K, lf.slope * K_se / K**2), "e-/s",
                                    "slope of mu_y.dark vs exposure / K")
        lv = line_fit(td.texp_s, td.s2_ydark)
        # EMVA 1288 4.0 Linear Section 7.1: the variance slope (DN^2/s) divided by K^2
        extra["u_I_var"] = (Estimate(lv.slope / K**2, math.hypot(lv.slope_se / K**2, 2 * lv.slope * K_se / K**3),
                                     "e-/s", "slope of s2_y.dark vs exposure / K^2 (EMVA 1288 4.0 Section 7.1)")
                            if lv.slope > 0 else na("dark variance does not grow with exposure", "e-/s"))

    if spatial_dark is not None:
        s2yd = spatial_dark.s2_spatial
        # (its SE: the temporal noise left in the stack average, as Release 4.0's
        # (``spatial.nonuniformity``), with K's; a variance not above 2 SE is an upper limit)
        vals["DSNU1288"] = (na(why_k, "e-") if why_k else
                            std_estimate(s2yd, _spatial_se(spatial_dark), 1.0 / K, K_se_e / K, "e-",
                                          "sqrt(s2_y.dark spatial)/K, stack average, temporal/L removed")
                            if s2yd >= 0 else na("negative dark spatial variance", "e-"))
        # in DN: the spatial std with its own SE (no K in it), as Release 4.0's (``nonuniformity.dsnu``)
        extra["DSNU1288_DN"] = (std_estimate(s2yd, _spatial_se(spatial_dark), 1.0, 0.0, "DN",
                                             "sqrt(s2_y.dark spatial), stack average, temporal/L removed")
                                if s2yd >= 0 else na("negative dark spatial variance", "DN"))
    else:
        vals["DSNU1288"] = na("no dark stack", "e-")
    if spatial_bright is not None and spatial_dark is not None:
        d2 = spatial_bright.s2_spatial - spatial_dark.s2_spatial
        sig = spatial_bright.mean - spatial_dark.mean
        vals["PRNU1288"] = (std_estimate(d2, math.hypot(_spatial_se(spatial_bright), _spatial_se(spatial_dark)),
                                          100.0 / sig, 0.0, "%",
                                          "sqrt(s2_y - s2_y.dark)/(mu_y - mu_y.dark), no high-pass (3.0)")
                            if d2 > 0 and sig > 0 else na("no spatial signal variance above dark", "%"))
    else:
        vals["PRNU1288"] = na("no bright and dark stacks", "%")

    dev, window, why_le = _linearity(td.u_p, Y, isat)
    # each extreme's SE: its level's deviation from the line through its mean's temporal noise (the
    # pair's mean over the pixels, bright and dark); one not resolved from 0 is only a limit
    # (``resolved``), never "ok". The side is the extreme's, not its sign's: the line makes the
    # weighted deviations sum to 0 over the window, so the max is >= 0 and the min <= 0 -- a max
    # not clear of 0 is only below max + 3 SE, a min only above min - 3 SE
    y_se = 100 * np.sqrt((td.s2_y + td.s2_ydark) / (2.0 * max(td.n_pixels, 1))) / np.where(Y != 0, np.abs(Y), np.inf)
    for key, pick in (("LE_min", np.argmin), ("LE_max", np.argmax)):
        if why_le:
            vals[key] = na(why_le, "%")
            continue
        j = window.start + int(pick(dev[window]))
        se = float(y_se[j]) if td.n_pixels else math.nan
        vals[key] = resolved(Estimate(float(dev[j]), se, "%", "5-95 % of saturation" + (
            "; SE: that level's mean's temporal noise" if td.n_pixels else "; no SE: the pixel count is not given")),
            key, side="upper" if key == "LE_max" else "lower")
    sat = vals.get("u_e_sat")
    tmax = float(np.max(td.texp_s)) if np.size(td.texp_s) else None
    vals, extra = (judge(vals, saturation=sat, longest_exposure_s=tmax),
                   judge(extra, saturation=sat, longest_exposure_s=tmax))
    return Emva1288Result(vals, isat, imax, dev, td, extra), gt


def _linearity(u_p: np.ndarray, Y: np.ndarray, isat: int) -> tuple[np.ndarray, slice, str]:
    """(deviation in % of every level from the line, the 5-95 % window, "" or why not
    available): the line fitted minimising relative deviations (reference implementation)."""
    nan = np.full(Y.shape, math.nan)
    if not Y[isat] > 0:
        return nan, slice(0, 0), "no signal at saturation"
    above, below = Y >= 0.05 * Y[isat], Y <= 0.95 * Y[isat]
    if np.count_nonzero(above & below) < 2:
        return nan, slice(0, 0), "fewer than two levels between 5 and 95 % of saturation"
    # the reference implementation's window: from the first level above 5 % to the last below 95 %
    lo, hi = int(np.argmax(above)), int(np.nonzero(below)[0][-1])
    X_, Y_ = u_p[lo:hi + 1], Y[lo:hi + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        xy = np.sum(X_ / Y_)
        xy2 = np.sum(X_ / Y_**2)
        x2y2 = np.sum((X_ / Y_) ** 2)
        _y = np.sum(1 / Y_)
        _y2 = np.sum(1 / Y_**2)
        b = (xy * xy2 - x2y2 * _y) / (xy2**2 - x2y2 * _y2)
        a = (xy - b * xy2) / x2y2
        line = a * u_p + b
        dev = 100 * (Y - line) / line
    if not (np.all(Y_ > 0) and np.all(np.isfinite(dev[lo:hi + 1]))):
        return nan, slice(0, 0), "no line through the photon counts fits the levels (photon counts zero or all equal)"
    return dev, slice(lo, hi + 1), ""


def _spatial_se(sp: SpatialStats) -> float:
    """SE (DN^2) of a stack average's spatial variance with s2_temporal / L removed, as a
    measurement of THIS sensor's pattern: the temporal noise t = s2_temporal / L left in the
    average over its n pixels -- var = 4 t s2_spatial / n (the pattern x noise cross term)
    + 2 t^2 / n (the noise's own chi-square) + 2 t^2 / (n (L - 1)) (the subtracted t is
    measured too): ``spatial.pattern_se.stack_variance_se``, Release 4.0's
    ``measurement_se`` without the high-pass and the split. Not the population's sampling spread sqrt(2 / n) s2 (another sensor of the
    same pattern statistics), which is what this returned before: 5 - 20x larger."""
    return stack_variance_se(sp.s2_spatial, sp.s2_temporal, sp.n_frames, sp.n_pixels)


def spatial_from_stacks(bright: np.ndarray, dark: np.ndarray) -> tuple[SpatialStats, SpatialStats]:
    return spatial_stats(bright), spatial_stats(dark)
