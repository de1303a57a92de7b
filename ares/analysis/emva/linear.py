"""EMVA 1288 Release 4.0 Linear: the photon-transfer parameter set (Sections 6.6 and 2.7).

From per-level statistics (``LevelStats`` with the Release 4.0 two-image temporal variance
of Eq. 18, i.e. ``pair_stats(..., offset_correction=True)``), the matched dark levels and
the photons per pixel of each level:

* saturation gray value mu_y.sat by the histogram criterion (Section 6.6): the brightest
  level at which at most 0.2 % of the pixels sit at the maximum code (the standard asks for
  0.1 - 0.2 %; a sweep whose levels skip that window gives a lower limit, one that never
  clips gives no saturation and no figure that needs it);
* responsivity R (Eq. 49, zero offset) and overall system gain K (Eq. 50, offset and
  slope) over the levels from the minimum to 70 % of saturation; quantum efficiency
  eta = R / K (Eq. 52); the local-slope linearity check (Eq. 51 as written:
  ``ptc_fit.local_slope_check_text``; ARES's noise-floor variant beside it,
  ``linear_noise_floor``, option ``eq51_noise_floor``);
* temporal dark noise sigma_y.dark (DN) at the lowest exposure and sigma_d (e-) without
  quantization noise (Eq. 53), or its upper limit 0.40 / K when sigma_y.dark^2 < 0.24
  (Eq. 54, sigma_y.dark set to 0.49);
* absolute sensitivity threshold mu_p.min by the exact Eq. 26 (the Eq. 88 form);
  saturation capacity mu_p.sat: the photons measured at the saturation step (Section 6.6,
  "Saturation capacity"), mu_e.sat = eta mu_p.sat (Eq. 24); SNR_max = sqrt(mu_e.sat) (Eq. 55)
  and the dynamic range DR = mu_p.sat / mu_p.min (Eq. 28), as ratios and in dB;
* the single linearity error LE (Section 6.9, Eqs. 59 - 63): mean |relative deviation|
  from the 1/y^2-weighted regression of mu_y - mu_y.dark on the photons, 5 - 95 % of
  saturation.

Every figure is an ``Estimate`` with its standard error, or not available with the reason.
Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ares.analysis.emva.gain_term import GainTerm, attribute, gain_term
from ares.analysis.stats.estimate import EXACT_PHOTONS, Estimate
from ares.analysis.ptc.levels import LevelStats
from ares.analysis.stats.physical import snr_db, snr_in_range
from ares.analysis.ptc.fit import LocalSlopeCheck

SAT_WINDOW = (0.001, 0.002)  # Section 6.6: 0.1 - 0.2 % of the pixels at the maximum value
FIT_MAX = 0.70  # Eqs. 49/50: 0 .. 70 % of saturation
LE_RANGE = (0.05, 0.95)  # Section 6.9: 5 .. 95 % of saturation
Q_VAR = 1.0 / 12.0  # quantization noise, DN^2


@dataclass
class Emva4Result:
    values: dict[str, Estimate]
    index_sat: int | None  # the saturation level (index into the sorted levels)
    fit_levels: list[int]  # levels of the K and R regressions
    le_levels: list[int]  # levels of the linearity error
    saturation: str  # one sentence: how mu_y.sat was found, or why not
    linear: bool | None = None  # the Eq. 51 local-slope check as written (None: could not be made)
    deviation_pct: np.ndarray = field(default_factory=lambda: np.zeros(0))  # Eq. 62 per level (NaN outside)
    notes: list[str] = field(default_factory=list)
    linear_check: "LocalSlopeCheck | None" = None  # Eq. 51 as written: mean |K_i - K|/K, P, sentence
    linear_noise_floor: "LocalSlopeCheck | None" = None  # ARES option eq51_noise_floor (beyond the text)
    mu_e_sat_fit: "Estimate | None" = None  # ARES's former (mu_y.sat - mu_y.dark) / K, for comparison only
    gain_term: "GainTerm | None" = None  # K as the zero-signal gain, in the figures in electrons (gain_term)

    def to_json(self) -> dict:
        return {k: v.to_dict() for k, v in self.values.items()}


def _ols(x: np.ndarray, y: np.ndarray, through_origin: bool) -> tuple[float, float, float]:
    """(slope, its SE, offset) of a least-squares line; SE from the residual scatter. NaN
    when the x values do not spread (no line)."""
    n = x.size
    if through_origin:
        sxx = float(np.dot(x, x))
        if not sxx > 0:
            return math.nan, math.nan, math.nan
        b = float(np.dot(x, y)) / sxx
        dof = n - 1
        r = y - b * x
        se = math.sqrt(float(np.dot(r, r)) / dof / sxx) if dof > 0 else math.nan
        return b, se, 0.0
    xm, ym = x.mean(), y.mean()
    sxx = float(np.dot(x - xm, x - xm))
    if not sxx > 0:
        return math.nan, math.nan, math.nan
    b = float(np.dot(x - xm, y - ym)) / sxx
    a = ym - b * xm
    dof = n - 2
    r = y - a - b * x
    se = math.sqrt(float(np.dot(r, r)) / dof / sxx) if dof > 0 else math.nan
    return b, se, a


def saturation_index(frac_at_max: np.ndarray) -> tuple[int | None, str, str | None]:
    """(index, sentence, bound) of the saturation level by the histogram criterion: the
    brightest level with at most 0.2 % of the pixels at the maximum code, provided a
    brighter level exceeds it; bound "lower" when that level is below the 0.1 % window."""
    lo, hi = SAT_WINDOW
    over = np.flatnonzero(frac_at_max > hi)
    if over.size == 0:
        return None, ("saturation not reached: no level has more than 0.2 % of its pixels at the maximum "
                      "value (EMVA 1288 4.0 Linear, Section 6.6)"), None
    below = np.flatnonzero(frac_at_max[: over[0]] <= hi)
    if below.size == 0:
        return None, ("saturation not found: already the first level has more than 0.2 % of its pixels at the "
                      "maximum value"), None
    i = int(below[-1])
    f = float(frac_at_max[i])
    if f >= lo:
        return i, (f"mu_y.sat at level {i}: {100 * f:.2f} % of the pixels at the maximum value, within the "
                   "0.1 - 0.2 % of Section 6.6"), None
    return i, (f"mu_y.sat at level {i} ({100 * f:.3f} % of the pixels at the maximum value; the next level has "
               f"{100 * float(frac_at_max[i + 1]):.2f} %): no level falls in the 0.1 - 0.2 % window of Section 6.6, "
               "so the saturation figures are lower limits"), "lower"


def linearity_error(y: np.ndarray, h: np.ndarray) -> tuple[float, float, np.ndarray]:
    """LE (%) by Eqs. 59 - 63: the 1/y^2-weighted regression y = a0 + a1 h, the relative
    deviations (Eq. 62) and their mean magnitude; returns (LE, SE of LE, deviations)."""
    w = 1.0 / (y * y)
    s_hy, s_h2y2, s_1y = float(np.sum(h / y)), float(np.sum(h * h * w)), float(np.sum(1.0 / y))
    s_1y2, s_hy2 = float(np.sum(w)), float(np.sum(h * w))
    delta = s_hy2 ** 2 - s_h2y2 * s_1y2  # Eq. 61
    a0 = (s_hy * s_hy2 - s_h2y2 * s_1y) / delta  # Eq. 59
    a1 = (s_hy2 * s_1y - s_hy * s_1y2) / delta  # Eq. 60
    fit = a0 + a1 * h
    dev = 100.0 * (y - fit) / fit  # Eq. 62
    mag = np.abs(dev)
    se = float(np.std(mag, ddof=1) / math.sqrt(mag.size)) if mag.size > 1 else math.nan
    return float(mag.mean()), se, dev  # Eq. 63


def emva4_linear(bright: Sequence[LevelStats], dark: Sequence[LevelStats], photons: Sequence[float],
                 dark_exposure_s: Sequence[float] | None = None, with_gain_term: bool = True) -> Emva4Result:
    """The Release 4.0 Linear parameter set (see the module docstring). ``bright[i]`` and
    ``dark[i]`` are level i and its dark at the same exposure; ``photons[i]`` is mu_p.
    Levels may come in any order: they are sorted by photons. The figures in electrons and
    photons carry K's uncertainty as the zero-signal gain (``gain_term``; ``with_gain_term``
    False: Eq. 50's own SE, what the notes compare against)."""
    r = _emva4_linear(bright, dark, photons, dark_exposure_s, with_gain_term)
    gt = r.gain_term
    if gt is not None and gt.widens:  # each figure's note: how much of its SE the gain term is
        plain = _emva4_linear(bright, dark, photons, dark_exposure_s, False, checks=False)
        r.values = attribute(r.values, plain.values, gt)
        r.notes.append(gt.sentence)
    return r


def _emva4_linear(bright: Sequence[LevelStats], dark: Sequence[LevelStats], photons: Sequence[float],
                  dark_exposure_s: Sequence[float] | None, with_gain_term: bool, checks: bool = True) -> Emva4Result:
    """``emva4_linear``; ``checks`` False: without the Eq. 51 checks (the SEs without the gain term only)."""
    from ares.analysis.ptc.fit import local_slope_check, local_slope_check_text

    order = np.argsort(np.asarray(photons, float), kind="stable")
    b = [bright[i] for i in order]
    d = [dark[i] for i in order]
    up = np.asarray(photons, float)[order]
    mu = np.array([x.mean for x in b]) - np.array([x.mean for x in d])
    var = np.array([x.var for x in b]) - np.array([x.var for x in d])
    frac = np.array([x.frac_at_max for x in b])
    v: dict[str, Estimate] = {}
    notes: list[str] = []
    isat, sat_text, bound = saturation_index(frac)
    y_sat = mu[isat] if isat is not None else math.nan
    limit = FIT_MAX * y_sat if isat is not None else np.inf
    fit = [i for i in range(len(b)) if 0 < mu[i] <= limit and np.isfinite(var[i])]  # Eq. 50: no photons needed
    lit = [i for i in fit if up[i] > 0]  # Eq. 49's
    if isat is None:
        notes.append("K and R fitted over every level with signal (saturation unknown: the 0 - 70 % range of "
                     "Eqs. 49/50 cannot be set)")

    def not_available(why: str) -> Emva4Result:
        for k, u in (("K", "DN/e-"), ("R", "DN/photon"), ("QE", "%")):
            v[k] = Estimate.na(why, u)
        return Emva4Result(v, isat, fit, [], sat_text, None, np.full(len(b), np.nan), notes)

    if len(fit) < 3:
        return not_available(f"needs >= 3 levels between the dark and 70 % of saturation, has {len(fit)}")
    x = np.asarray(fit)
    K, K_se, _ = _ols(mu[x], var[x], through_origin=False)  # Eq. 50
    if not (K > 0 and math.isfinite(K_se)):
        return not_available(f"the temporal variance does not rise with the signal (slope {K:.3g} DN/e-)")
    v["K"] = Estimate(K, K_se, "DN/e-", "slope of s2_y - s2_y.dark vs mu_y - mu_y.dark, 0-70 % of saturation "
                                        "(EMVA 1288 4.0 Linear Eq. 50)")
    var_se = np.hypot([q.var_se for q in b], [q.var_se for q in d])
    gt = gain_term(mu[x], var[x], var_se[x], [b[i].dof for i in x], v["K"]) if with_gain_term else None
    K_se_e = gt.se if gt is not None else K_se  # K's SE in the figures in electrons and photons (gain_term)
    R, R_se, _ = _ols(up[lit], mu[lit], through_origin=True) if len(lit) >= 3 else (math.nan, math.nan, 0.0)  # Eq. 49
    why_r = ("" if R > 0 and math.isfinite(R_se) else
             f"needs photon counts > 0 at >= 3 of those levels, has {len(lit)}" if len(lit) < 3 else
             f"the signal does not rise with the photon counts (slope {R:.3g} DN/photon)")
    eta = math.nan
    if why_r:
        v["R"], v["QE"] = Estimate.na(why_r, "DN/photon"), Estimate.na(why_r, "%")
    else:
        v["R"] = Estimate(R, R_se, "DN/photon", "slope of mu_y - mu_y.dark vs mu_p through 0 (Eq. 49)")
        eta = R / K
        v["QE"] = Estimate(100 * eta, 100 * eta * math.hypot(R_se / R, K_se_e / K), "%", "eta = R / K (Eq. 52)")
    if not checks:  # (the figures' SEs without the gain term, for their notes: the checks are not needed)
        check, floor_check = LocalSlopeCheck(math.nan, None, ""), None
    elif isat is not None:  # Eq. 51 as written: the spline over every level up to saturation
        upto = np.arange(isat + 1)
        check = local_slope_check_text(mu[upto], var[upto], K, y_sat)
    else:
        check = LocalSlopeCheck(math.nan, None, "Eq. 51 needs the saturation (its B-spline runs from 0 to it): "
                                                + sat_text)
    if checks:
        floor_check = local_slope_check(mu[x], var[x], var_se[x], K)  # ARES option eq51_noise_floor
    notes.append(check.note)
    linear = check.holds

    # temporal dark noise at the lowest exposure (Eqs. 53/54)
    j = int(np.argmin(np.asarray(dark_exposure_s, float)[order])) if dark_exposure_s is not None else 0
    s2d = d[j].var
    s2d_se = d[j].var_se
    small = s2d < 0.24
    sy = 0.49 if small else math.sqrt(s2d)
    v["sigma_y_dark"] = (Estimate.limit(0.49, "upper", "DN", "sigma_y.dark^2 < 0.24 DN^2: quantization dominates "
                                                             "(Eq. 54)") if small else
                         Estimate(sy, s2d_se / (2 * sy), "DN", "temporal dark noise at the lowest exposure"))
    if small:
        v["sigma_d"] = Estimate.limit(0.40 / K, "upper", "e-", "0.40 / K (EMVA 1288 4.0 Linear Eq. 54)")
    else:
        sd = math.sqrt(max(s2d - Q_VAR, 0.0)) / K
        sd_se = sd * math.hypot(s2d_se / (2 * max(s2d - Q_VAR, 1e-12)), K_se_e / K)
        v["sigma_d"] = Estimate(sd, sd_se, "e-", "sqrt(sigma_y.dark^2 - 1/12) / K (Eq. 53)")
    # absolute sensitivity threshold, exact (Eq. 26 in the Eq. 88 form)
    a = sy / K
    root = math.sqrt(a * a + 0.25)
    mu_e_min = root + 0.5
    a_rel = math.hypot(0.0 if small else v["sigma_y_dark"].se / sy, K_se_e / K)
    mu_e_min_se = a * a / root * a_rel
    if small:
        v["mu_e_min"] = Estimate.limit(mu_e_min, "upper", "e-", "sqrt(sigma_y.dark^2/K^2 + 1/4) + 1/2 (Eq. 26)")
    else:
        v["mu_e_min"] = Estimate(mu_e_min, mu_e_min_se, "e-", "sqrt(sigma_y.dark^2/K^2 + 1/4) + 1/2 (Eq. 26)")
    if why_r:
        v["mu_p_min"] = Estimate.na(why_r, "photons")
    elif small:
        v["mu_p_min"] = Estimate.limit(mu_e_min / eta, "upper", "photons", "mu_e.min / eta (Eq. 26)")
    else:
        v["mu_p_min"] = Estimate(mu_e_min / eta, (mu_e_min / eta) * math.hypot(mu_e_min_se / mu_e_min,
                                                                                v["QE"].se / v["QE"].value),
                                 "photons", "mu_e.min / eta (Eq. 26)")
    # saturation and what depends on it
    le_levels: list[int] = []
    dev = np.full(len(b), np.nan)
    if isat is None:
        for k, u in (("mu_y_sat", "DN"), ("mu_p_sat", "photons"), ("mu_e_sat", "e-"), ("SNR_max", ""),
                     ("SNR_max_db", "dB"), ("DR", ""), ("DR_db", "dB"), ("LE", "%")):
            v[k] = Estimate.na(sat_text, u)
        return Emva4Result(v, isat, fit, le_levels, sat_text, linear, dev, notes, check, floor_check, gain_term=gt)
    n_b = b[isat]
    y_se = math.sqrt(max(n_b.var, 0.0) / max(n_b.n_pixels * n_b.n_frames, 1))

    def est(val, rel, unit, note):
        e = Estimate(val, abs(val) * rel, unit, note)
        return Estimate.limit(val, bound, unit, note + "; lower limit (no level in the 0.1 - 0.2 % window)") \
            if bound else e

    v["mu_y_sat"] = est(y_sat, y_se / y_sat, "DN", "mu_y.sat - mu_y.dark by the histogram criterion (Section 6.6)")
    e_fit = est(y_sat / K, math.hypot(y_se / y_sat, K_se_e / K), "e-", "(mu_y.sat - mu_y.dark) / K (ARES before "
                                                                    "issue 35; not the text)")
    p_sat = float(up[isat])  # the photons measured at the saturation step (Section 6.6)
    if why_r or not p_sat > 0:
        why = why_r or "no photon count at the saturation step"
        for k, u in (("mu_p_sat", "photons"), ("mu_e_sat", "e-"), ("SNR_max", ""), ("SNR_max_db", "dB")):
            v[k] = Estimate.na(why, u)
    else:
        eta_rel = v["QE"].se / v["QE"].value
        note = "photons at the saturation step (EMVA 1288 4.0 Linear Section 6.6)"
        v["mu_p_sat"] = est(p_sat, 0.0, "photons", note) if bound else \
            Estimate.declared(p_sat, "photons", EXACT_PHOTONS, note)  # not measured here: no SE to state
        mu_e_sat = eta * p_sat
        v["mu_e_sat"] = est(mu_e_sat, eta_rel, "e-", "eta mu_p.sat (Eq. 24)")
        snr = math.sqrt(mu_e_sat)
        rel_snr = 0.5 * eta_rel if not bound else 0.0
        # no sensor beats the photon shot noise: SNR_max <= sqrt(mu_p.sat) (an eta above 1 breaks it)
        v["SNR_max"] = snr_in_range(est(snr, rel_snr, "", "sqrt(mu_e.sat) (Eq. 55)"), p_sat, "SNR_max",
                                    "the photons at saturation")
        v["SNR_max_db"] = snr_db(v["SNR_max"], "20 log10 SNR_max")
    if not v["mu_p_sat"].available:
        v["DR"], v["DR_db"] = Estimate.na(v["mu_p_sat"].note, ""), Estimate.na(v["mu_p_sat"].note, "dB")
    elif not v["mu_p_min"].available:
        v["DR"], v["DR_db"] = Estimate.na(v["mu_p_min"].note, ""), Estimate.na(v["mu_p_min"].note, "dB")
    elif v["mu_p_min"].bound:  # DR from an upper-limit threshold and the saturation: a lower limit
        dr = p_sat / v["mu_p_min"].value
        v["DR"] = Estimate.limit(dr, "lower", "", "mu_p.sat / mu_p.min (Eq. 28); mu_p.min is an upper limit")
        v["DR_db"] = Estimate.limit(20 * math.log10(dr), "lower", "dB", "20 log10 DR")
    else:
        dr = p_sat / v["mu_p_min"].value
        rel = v["mu_p_min"].se / v["mu_p_min"].value
        v["DR"] = est(dr, rel, "", "mu_p.sat / mu_p.min (Eq. 28)")
        v["DR_db"] = Estimate.limit(20 * math.log10(dr), bound, "dB", "20 log10 DR") if bound else \
            Estimate(20 * math.log10(dr), 20 / math.log(10) * rel, "dB", "20 log10 DR")
    lo, hi = LE_RANGE
    le_levels = [i for i in range(len(b)) if lo * y_sat <= mu[i] <= hi * y_sat and up[i] > 0]
    if len(le_levels) < 3:
        v["LE"] = Estimate.na(f"needs >= 3 levels between 5 and 95 % of saturation, has {len(le_levels)}", "%")
    else:
        li = np.asarray(le_levels)
        le, le_se, dv = linearity_error(mu[li], up[li])
        dev[li] = dv
        v["LE"] = Estimate(le, le_se, "%", "mean |deviation| from the 1/y^2-weighted line, 5-95 % of saturation "
                                           "(Eqs. 59-63)")
    return Emva4Result(v, isat, fit, le_levels, sat_text, linear, dev, notes, check, floor_check, e_fit, gt)
