"""EMVA 1288 Release 4.0 General: the characteristic curve and the input SNR of a camera with
no linearity assumption (General document, Sections 2.2, 2.4, 6.6 - 6.8).

* cubic B-spline regression (General Eqs. 44 - 47) of mu_y - mu_y.dark against mu_p over
  P intervals of 0 .. mu_p.sat, and its analytic slope (Eqs. 48 - 49);
* output SNR_y = (mu_y - mu_y.dark) / sigma_y (Eq. 7) and input SNR_p = mu_p / sigma_y *
  d mu_y / d mu_p (Eq. 10); the ideal sensor sqrt(mu_p) (Eq. 15);
* mu_p.min: the B-spline regression of the inverse relation mu_p(SNR_p) over the levels
  below saturation, evaluated at SNR_p = 1 (Section 6.8), only where the steps reach
  SNR_p = 1 (else the upper limit "below the lowest step"); SNR_max: the largest SNR_p;
* saturation mu_p.sat by the histogram criterion (Section 6.7, as Linear Section 6.6);
  DR = mu_p.sat / mu_p.min (Eq. 21);
* temporal dark noise sigma_y.dark (DN, quantization included): with the exposure time
  varied (method I of Section 6.3) the offset at t = 0 of the regression of sigma_y.dark^2
  over the exposure times, else the darks at the lowest exposure; sigma_d in photons:
  sqrt(sigma_y.dark^2 - 1/12) / R_d with R_d the slope of the characteristic curve at
  mu_p = 0 (Eq. 50), or the upper limit 0.40 / R_d when sigma_y.dark^2 < 0.24 (Eq. 51).

K, the quantum efficiency and anything in electrons are not defined in the General model
(Section 6.7): Table 2's rows for them say "cannot be measured" (``emva_general_table``, which
completes Table 2 of the General document: photon units, nonuniformity Eqs. 55 - 60,
dark current in photons/s). Standard errors: the B-spline fits are linear least squares, so a value that
is a linear functional of the coefficients gets the SE from the coefficient covariance
(residual scatter); mu_p.min's SE also carries the scatter of the SNR_p points.
Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ares.analysis.emva.linear import saturation_index
from ares.analysis.stats.estimate import EXACT_PHOTONS, Estimate
from ares.analysis.stats.splines import BSpline, bspline_fit, intervals_for
from ares.analysis.stats.physical import snr_db, snr_in_range
from ares.analysis.ptc.levels import LevelStats


def _threshold_below(up: np.ndarray, snr: np.ndarray, n: int = 5) -> Estimate:
    """mu_p at SNR_p = 1 below the lowest step: near the threshold any sensor's input SNR
    follows mu_p / sqrt(a + c mu_p) (a fixed noise floor and shot noise referred to the
    input), i.e. 1/SNR^2 = a/mu_p^2 + c/mu_p, fitted to the ``n`` lowest steps."""
    x, y = up[:n], 1.0 / snr[:n] ** 2
    A = np.vstack([1 / x**2, 1 / x]).T
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ coef
    dof = max(x.size - 2, 1)
    cov = float(r @ r) / dof * np.linalg.pinv(A.T @ A)

    def root(a, c):
        return (c + math.sqrt(c * c + 4 * a)) / 2 if c * c + 4 * a >= 0 else math.nan

    a, c = (float(t) for t in coef)
    val = root(a, c)
    if not math.isfinite(val) or val <= 0:
        return Estimate.na("every step has SNR_p > 1 and the lowest steps do not extrapolate to SNR_p = 1",
                           "photons")
    h = 1e-6 * max(abs(a), abs(c), 1e-12)
    g = np.array([(root(a + h, c) - val) / h, (root(a, c + h) - val) / h])
    se = math.sqrt(max(float(g @ cov @ g), 0.0))
    return Estimate(val, se, "photons", f"SNR_p = 1 extrapolated from the {x.size} lowest steps by "
                                        "1/SNR_p^2 = a/mu_p^2 + c/mu_p (every step has SNR_p > 1)")


@dataclass
class GeneralResult:
    values: dict[str, Estimate]
    curve: BSpline | None  # characteristic curve mu_y - mu_y.dark vs mu_p
    photons: np.ndarray  # sorted mu_p of the levels
    signal: np.ndarray  # mu_y - mu_y.dark
    sigma_y: np.ndarray  # temporal sigma (Eq. 18), DN
    snr_y: np.ndarray  # Eq. 7
    snr_p: np.ndarray  # Eq. 10 (NaN where the slope is not positive)
    mean_diff: np.ndarray  # mu[0] - mu[1] of each pair (the stability graph, Section 6.7)
    index_sat: int | None
    saturation: str
    notes: list[str] = field(default_factory=list)
    snr_p_total: "np.ndarray | None" = None  # Eq. 60 per step (when the steps' spatial variances are known)

    def to_json(self) -> dict:
        return {k: v.to_dict() for k, v in self.values.items()}


def emva_general(bright: list[LevelStats], dark: list[LevelStats], photons, mean_diff=None,
                 dark_var_lowest: LevelStats | None = None, intervals: int | None = None, *,
                 exposure_s=None, table: dict | None = None) -> GeneralResult:
    """The Release 4.0 General evaluation (see the module docstring). ``bright[i]``/``dark[i]``
    are level i and its dark (two-image statistics, Eq. 18); ``photons[i]`` its mu_p;
    ``exposure_s[i]`` its exposure time (method I: the dark noise is the regression's offset).
    ``table``: keyword arguments of ``emva_general_table.complete`` (stacks, dark series,
    pixel area, the Linear result) -- the whole of Table 2 is always given, each entry a value
    or the reason it is not."""
    order = np.argsort(np.asarray(photons, float), kind="stable")
    up = np.asarray(photons, float)[order]
    b = [bright[i] for i in order]
    d = [dark[i] for i in order]
    sig = np.array([x.mean for x in b]) - np.array([x.mean for x in d])
    var = np.array([x.var for x in b])
    sy = np.sqrt(np.maximum(var, 0.0))
    md = np.asarray(mean_diff, float)[order] if mean_diff is not None else np.full(up.size, np.nan)
    texp = np.asarray(exposure_s, float)[order] if exposure_s is not None else None
    isat, sat_text, bound = saturation_index(np.array([x.frac_at_max for x in b]))
    v: dict[str, Estimate] = {}
    notes: list[str] = []
    top = isat if isat is not None else up.size - 1
    use = np.arange(top + 1)
    P = intervals if intervals is not None else intervals_for(use.size)
    snr_y = np.where(sy > 0, sig / np.where(sy > 0, sy, 1.0), np.nan)
    snr_p = np.full(up.size, np.nan)
    na = ""
    if use.size <= P + 3:
        na = f"needs more than {P + 3} levels up to saturation for a {P}-interval B-spline, has {use.size}"
    elif not float(up[top]) > 0:
        na = "the photon counts are zero up to saturation: no characteristic curve"
    if na:
        for k, u in (("mu_p_min", "photons"), ("mu_p_sat", "photons"), ("DR", ""), ("DR_db", "dB"),
                     ("SNR_max", ""), ("SNR_max_db", "dB"), ("sigma_d", "photons"), ("R_d", "DN/photon")):
            v[k] = Estimate.na(na, u)
        res = GeneralResult(v, None, up, sig, sy, snr_y, snr_p, md, isat, sat_text, notes)
        from ares.analysis.emva.general_table import complete

        complete(res, d, texp, **(table or {}))
        return res
    x_max = float(up[top])
    curve = bspline_fit(up[use], sig[use], P, x_max)  # Eq. 47: the measured points only
    slope = curve.slope(up)
    ok = (slope > 0) & (sy > 0) & (up > 0)
    snr_p[ok] = up[ok] / sy[ok] * slope[ok]  # Eq. 10
    # temporal dark noise (Section 6.7 "Temporal dark noise"), sigma_d in photons (Eqs. 50/51)
    dl = dark_var_lowest if dark_var_lowest is not None else d[0]
    s2d, s2d_se, how = dl.var, dl.var_se, "temporal dark noise at the lowest exposure"
    from ares.analysis.stats.median import n_distinct  # (np.unique would import numpy.ma)

    if dark_var_lowest is None and texp is not None and n_distinct(texp) >= 2:  # method I (Section 6.7)
        from ares.analysis.ptc.fit import line_fit

        lf = line_fit(texp, np.array([x.var for x in d]))
        s2d, s2d_se = lf.intercept, lf.intercept_se
        how = "offset at t = 0 of sigma_y.dark^2 over the exposure times (General Section 6.7, method I)"
    rd = float(curve.slope(0.0))
    rd_se = float(curve.se(0.0, derivative=True))
    v["R_d"] = Estimate(rd, rd_se, "DN/photon", "slope of the characteristic curve at mu_p = 0 (Eq. 25)")
    small = s2d < 0.24
    v["sigma_y_dark"] = Estimate.limit(0.49, "upper", "DN", "sigma_y.dark^2 < 0.24: quantization dominates") if \
        small else Estimate(math.sqrt(s2d), s2d_se / (2 * math.sqrt(s2d)), "DN", how)
    if rd <= 0:
        v["sigma_d"] = Estimate.na("the characteristic curve does not rise at mu_p = 0", "photons")
    elif small:
        v["sigma_d"] = Estimate.limit(0.40 / rd, "upper", "photons", "0.40 / R_d (General Eq. 51)")
    else:
        sd = math.sqrt(max(s2d - 1 / 12, 0.0)) / rd
        v["sigma_d"] = Estimate(sd, sd * math.hypot(s2d_se / (2 * max(s2d - 1 / 12, 1e-12)), rd_se / rd),
                                "photons", "sqrt(sigma_y.dark^2 - 1/12) / R_d (General Eq. 50)")
    # mu_p.min: B-spline of mu_p(SNR_p) at SNR_p = 1 (Section 6.8)
    k = np.flatnonzero(ok[: top + 1])
    if k.size > 5 and np.nanmin(snr_p[k]) < 1 < np.nanmax(snr_p[k]):
        inv = bspline_fit(snr_p[k], up[k], intervals_for(k.size), float(np.nanmax(snr_p[k])))
        v["mu_p_min"] = Estimate(float(inv(1.0)), float(inv.se(1.0)), "photons",
                                 "B-spline of mu_p vs SNR_p at SNR_p = 1 (General Section 6.8)")
    elif k.size > 5 and np.nanmin(snr_p[k]) >= 1:
        low = float(up[k[0]])
        v["mu_p_min"] = Estimate.limit(low, "upper", "photons", f"below the lowest step: every step has SNR_p > 1, "
                                                                 f"so mu_p.min < {low:.4g} photons (the regression "
                                                                 "of Section 6.8 has no step at SNR_p = 1)")
        notes.append("no exposure step reaches down to SNR_p = 1 (General Section 6.5 asks for steps where the "
                     "input SNR is about one): mu_p.min is only known to be below the lowest step; ARES's "
                     "extrapolation (option general_threshold_extrapolated, beyond the text) is "
                     + _threshold_below(up[k], snr_p[k]).text())
    else:
        v["mu_p_min"] = Estimate.na("too few levels with a positive slope of the characteristic curve", "photons")
    if ok[: top + 1].any():
        j = int(np.nanargmax(np.where(ok[: top + 1], snr_p[: top + 1], -np.inf)))
        smax = float(snr_p[j])
        smax_se = smax * math.sqrt(1.0 / max(b[j].dof, 1) * 0.5 + (float(curve.se(up[j], True)) / slope[j]) ** 2)
        # no sensor beats the photon shot noise: SNR_p <= sqrt(mu_p) at that level
        v["SNR_max"] = snr_in_range(Estimate(smax, smax_se, "", f"largest SNR_p (level {j}, Section 6.8)"),
                                    float(up[j]), "SNR_max", f"the photons at level {j}")
        v["SNR_max_db"] = snr_db(v["SNR_max"], "20 log10 SNR_max")
    else:
        why = "no level up to saturation with a rising characteristic curve and temporal noise"
        v["SNR_max"], v["SNR_max_db"] = Estimate.na(why, ""), Estimate.na(why, "dB")
    if isat is None:
        for key, u in (("mu_p_sat", "photons"), ("DR", ""), ("DR_db", "dB")):
            v[key] = Estimate.na(sat_text, u)
    else:
        psat = float(up[isat])
        v["mu_p_sat"] = (Estimate.limit(psat, "lower", "photons", "photons at mu_y.sat; lower limit") if bound else
                         Estimate.declared(psat, "photons", EXACT_PHOTONS, "photons at mu_y.sat (histogram criterion)"))
        mn = v["mu_p_min"]
        if mn.available and psat > 0 and mn.value > 0:
            dr = psat / mn.value
            if mn.bound == "upper" or bound:
                v["DR"] = Estimate.limit(dr, "lower", "", "mu_p.sat / mu_p.min (General Eq. 21)")
                v["DR_db"] = Estimate.limit(20 * math.log10(dr), "lower", "dB", "20 log10 DR")
            else:
                rel = mn.se / mn.value
                v["DR"] = Estimate(dr, dr * rel, "", "mu_p.sat / mu_p.min (General Eq. 21)")
                v["DR_db"] = Estimate(20 * math.log10(dr), 20 / math.log(10) * rel, "dB", "20 log10 DR")
        else:
            why = "mu_p.min not available" if not mn.available else "no photons at saturation or at mu_p.min"
            v["DR"], v["DR_db"] = Estimate.na(why, ""), Estimate.na(why, "dB")
    res = GeneralResult(v, curve, up, sig, sy, snr_y, snr_p, md, isat, sat_text, notes)
    from ares.analysis.emva.general_table import complete

    complete(res, d, texp, **(table or {}))
    return res


def general_from_input(inp, linear=None):
    """``emva_general`` of an ``emva4_sheet.EmvaInput`` with the whole of Table 2 (the stacks,
    the dark series, the pixel area and the exposure times it carries); ``linear``: the
    Linear ``Emva4Result`` of the same data."""
    s2 = None
    if inp.step_split is not None:  # the bright pair's spatial variance at each step (Eq. 32), sorted
        order = np.argsort(np.asarray(inp.photons, float), kind="stable")
        s2 = np.array([inp.step_split[i][0].total for i in order])
    return emva_general(inp.bright, inp.dark, inp.photons, mean_diff=inp.mean_diff, exposure_s=inp.exposure_s,
                        table=dict(stack_dark=inp.stack_dark, stack_bright=inp.stack_bright,
                                   dark_series=inp.dark_series, pixel_area_um2=inp.pixel_area_um2, linear=linear,
                                   step_spatial_var=s2))
