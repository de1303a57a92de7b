"""Photon-transfer fits of temporal variance ``V`` against signal ``S`` (both in DN).

- ``origin_fit``: ordinary least squares through the origin (EMVA 1288 ``K``).
- ``wls_line``: weighted least squares ``V = K*S + c`` with ``var(V) ~ 2 V^2 / N``
  (``N`` degrees of freedom of each variance), optionally through the origin.
- ``astier_fit``: Astier et al. 2019 (arXiv:1905.08677) eq. 16 restricted to C00,
  ``V = (exp(2 a00 S g) - 1) / (2 a00 g^2) + n00 / g^2`` with ``g`` in e-/DN;
  ``a00 -> 0`` gives the line ``V = S/g + n00/g^2``.

- ``choose_gain_model``: the line or the Astier form, chosen by the data (an F-test of the
  extra curvature term and the significance of ``a00``), with both residual tests reported.
- ``local_slope_check_text``: EMVA 1288 4.0 Linear, Section 6.6, Eq. 51 as written -- the
  cubic B-spline regression of the General document (Eqs. 44 - 49: P equal intervals from 0
  to saturation, unweighted least squares) through the photon transfer curve; the mean
  |K_i - K| / K of its local slopes at the levels within 0 - 70 % of saturation must stay
  below 3 % for the linear model to hold.
- ``max_relative_deviation``: the linearity error -- the largest |relative deviation| of
  the signal from a line fitted with 1/S weights -- with its SE propagated from each
  level's signal SE (delta method through the fit, at the extreme level).
- ``local_slope_check``: ARES's variant (option ``eq51_noise_floor``): a weighted spline with
  at most three interior knots at signal quantiles over the fitted levels only, the linear
  model rejected only when the deviation exceeds 3 % by more than the noise of the local
  slopes. Reported beside the text's check, never instead of it.

Every fit returns a ``LineFit``/``AstierFit`` with standard errors; the covariance is
scaled by the reduced chi-square when that exceeds one (model scatter beyond the
Gaussian error model is never hidden).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.lsq import levenberg_marquardt
from ares.analysis.stats.median import sorted_quantiles


@dataclass(frozen=True)
class LineFit:
    slope: float
    slope_se: float
    intercept: float = 0.0
    intercept_se: float = 0.0
    chi2_red: float = math.nan
    n: int = 0


def origin_fit(x, y, y_se=None) -> LineFit:
    """Unweighted least squares ``y = k x`` (the EMVA 1288 fit).

    SE: with ``y_se`` (per-point errors) the propagated ``sqrt(sum x^2 s^2)/sum x^2``,
    scaled by the reduced chi-square when above one -- residual-only SEs understate the
    error when the errors grow with ``y`` (as variances do); without ``y_se`` from the
    residuals."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.size < 1 or not np.any(x):
        return LineFit(math.nan, math.nan, n=x.size)
    sxx = float(np.sum(x * x))
    k = float(np.sum(x * y)) / sxx
    r = y - k * x
    if y_se is not None and x.size > 1:
        e = np.broadcast_to(np.asarray(y_se, float), x.shape)
        chi2 = float(np.sum((r / e) ** 2)) / (x.size - 1)
        se = math.sqrt(float(np.sum(x * x * e * e))) / sxx * math.sqrt(max(chi2, 1.0))
        return LineFit(k, se, 0.0, 0.0, chi2, x.size)
    se = math.sqrt(float(np.sum(r * r)) / (x.size - 1) / sxx) if x.size > 1 else math.nan
    return LineFit(k, se, 0.0, 0.0, math.nan, x.size)


def line_fit(x, y) -> LineFit:
    """Unweighted straight line ``y = a x + b`` with SEs from the residuals."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    n = x.size
    if n < 2:
        return LineFit(math.nan, math.nan, math.nan, math.nan, n=n)
    A = np.vstack([x, np.ones_like(x)]).T
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ coef
    if n > 2:
        s2 = float(r @ r) / (n - 2)
        cov = s2 * np.linalg.inv(A.T @ A)
        se = np.sqrt(np.diag(cov))
    else:
        se = np.array([math.nan, math.nan])
    return LineFit(float(coef[0]), float(se[0]), float(coef[1]), float(se[1]), math.nan, n)


def t_quantile(p: float, dof: float) -> float:
    """Student's t quantile: the ``t`` with ``P(T_dof <= t) = p`` (p > 0.5), by bisection on
    ``P(T > t) = I_{dof/(dof+t^2)}(dof/2, 1/2) / 2`` (``stats.tails.beta_i``; scipy.stats.t.ppf
    within 1e-12 relative, tested) -- without importing scipy.stats."""
    from ares.analysis.stats.tails import beta_i

    if not (dof >= 1 and 0.5 < p < 1):
        return math.inf if dof < 1 else math.nan
    lo, hi = 0.0, 1e7
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if 0.5 * beta_i(dof / 2, 0.5, dof / (dof + mid * mid)) > 1 - p:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-13 * hi:
            break
    return 0.5 * (lo + hi)


RESIDUAL_T_P = 0.99865  # the one-sided coverage of 3 normal SEs: a 3-SE decision's width


def residual_se_widening(dof: int) -> float:
    """The factor an SE taken from the residual scatter of a fit with ``dof`` degrees of
    freedom must carry so that 3 of them cover what 3 normal SEs do: Student's t quantile
    / 3 (1 dof: 78.6, 2: 6.4, 3: 3.07, 10: 1.32, 30: 1.09). Such an SE is itself uncertain
    by ~1/sqrt(2 dof) (70 % with 1 dof)."""
    return t_quantile(RESIDUAL_T_P, dof) / 3.0 if dof >= 1 else math.inf


def wls_line(s, v, dof, through_origin: bool = False, v_se=None) -> LineFit:
    """Weighted least squares of variance vs signal, ``w = N / (2 V^2)``, or
    ``w = 1 / v_se^2`` when per-point errors ``v_se`` are given (e.g. the error of a
    dark-subtracted variance, or an effective variance including the signal's error)."""
    s = np.asarray(s, float)
    v = np.asarray(v, float)
    dof = np.broadcast_to(np.asarray(dof, float), s.shape)
    if v_se is not None:
        sig = np.maximum(np.broadcast_to(np.asarray(v_se, float), s.shape), 1e-12)
    else:
        sig = np.sqrt(2.0 / dof) * np.maximum(np.abs(v), 1e-12)
    w = 1.0 / sig**2
    if through_origin:
        A = s[:, None]
    else:
        A = np.vstack([s, np.ones_like(s)]).T
    n, p = A.shape
    if n < p + 1:
        return LineFit(math.nan, math.nan, math.nan, math.nan, n=n)
    Aw = A * np.sqrt(w)[:, None]
    yw = v * np.sqrt(w)
    coef, *_ = np.linalg.lstsq(Aw, yw, rcond=None)
    r = yw - Aw @ coef
    chi2 = float(r @ r) / (n - p)
    try:
        cov = np.linalg.inv(Aw.T @ Aw) * max(chi2, 1.0)
    except np.linalg.LinAlgError:  # the weights single out fewer levels than parameters: no fit
        return LineFit(math.nan, math.nan, math.nan, math.nan, n=n)
    if not np.all(np.diag(cov) >= 0):  # (the same, seen through rounding)
        return LineFit(math.nan, math.nan, math.nan, math.nan, n=n)
    se = np.sqrt(np.diag(cov))
    if through_origin:
        return LineFit(float(coef[0]), float(se[0]), 0.0, 0.0, chi2, n)
    return LineFit(float(coef[0]), float(se[0]), float(coef[1]), float(se[1]), chi2, n)


@dataclass(frozen=True)
class AstierFit:
    gain_e_per_dn: float
    gain_se: float
    a00: float  # 1/e-
    a00_se: float
    n00: float  # e-^2 (noise term of the dark-subtracted variance)
    n00_se: float
    chi2_red: float
    n: int

    @property
    def gain_dn_per_e(self) -> float:
        return 1.0 / self.gain_e_per_dn


def astier_model(mu, a00, g, n00):
    mu = np.asarray(mu, float)
    x = 2.0 * a00 * mu * g
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        lin = np.where(np.abs(x) < 1e-8, mu / g * (1.0 + x / 2.0), np.expm1(x) / (2.0 * a00 * g * g))
    return lin + n00 / (g * g)


def astier_fit(s, v, dof, v_se=None) -> AstierFit:
    """Fit the exponential approximation with weights ``N / (2 V^2)`` (or ``1/v_se^2``)."""
    s = np.asarray(s, float)
    v = np.asarray(v, float)
    dof = np.broadcast_to(np.asarray(dof, float), s.shape)
    if s.size < 4:
        nan = math.nan
        return AstierFit(nan, nan, nan, nan, nan, nan, nan, s.size)
    if v_se is not None:
        sig = np.maximum(np.broadcast_to(np.asarray(v_se, float), s.shape), 1e-12)
    else:
        sig = np.sqrt(2.0 / dof) * np.maximum(np.abs(v), 1e-12)
    lf = wls_line(s, v, dof, v_se=sig)
    g0 = 1.0 / lf.slope if lf.slope > 0 else 1.0
    p0 = np.array([0.0, g0, lf.intercept * g0 * g0])
    # a00's scale: the curvature that bends the PTC by a factor ~e over the levels' range
    a_scale = 1.0 / (2.0 * g0 * max(float(np.max(np.abs(s))), 1e-12))
    fit = levenberg_marquardt(lambda p: astier_model(s, *p), v, sig, p0, scale=(a_scale, g0, 1.0))
    if fit is None:
        nan = math.nan
        return AstierFit(nan, nan, nan, nan, nan, nan, nan, s.size)
    popt, pcov = fit
    r = (v - astier_model(s, *popt)) / sig
    chi2 = float(r @ r) / max(s.size - 3, 1)
    var = np.diag(pcov) * max(chi2, 1.0)
    if not np.all(np.isfinite(var) & (var > 0)):  # J^T J singular to rounding: the parameters are not
        nan = math.nan                              # determined by these levels (no SE, so no fit)
        return AstierFit(nan, nan, nan, nan, nan, nan, nan, s.size)
    se = np.sqrt(var)
    return AstierFit(float(popt[1]), float(se[1]), float(popt[0]), float(se[0]), float(popt[2]),
                     float(se[2]), chi2, s.size)


@dataclass(frozen=True)
class GainModel:
    """Which photon-transfer model the data support, and the residual tests behind it."""

    chosen: str  # "linear" | "astier"
    line: LineFit
    astier: AstierFit | None
    line_p: float  # chi-square probability of the line's residuals (1 = consistent)
    astier_p: float
    f_p: float  # F-test probability that the curvature term is not needed
    reason: str

    def to_dict(self) -> dict:
        def num(x):
            return x if isinstance(x, (int, float)) and math.isfinite(x) else None
        d = {"chosen": self.chosen, "reason": self.reason, "levels": self.line.n,
             "line_chi2_red": num(self.line.chi2_red), "line_p": num(self.line_p),
             "astier_chi2_red": num(self.astier.chi2_red) if self.astier else None,
             "astier_p": num(self.astier_p), "curvature_f_test_p": num(self.f_p)}
        if self.astier is not None:
            d["a00_per_e"] = num(self.astier.a00)
            d["a00_se"] = num(self.astier.a00_se)
        return d


def choose_gain_model(s, v, dof, v_se=None, p_min: float = 1e-3) -> GainModel:
    """The Astier form wherever >= 5 levels determine it (the line is its a00 = 0 case;
    see the comment below), else the line ``V = K S + c``; both residual tests and the
    F-test of the curvature term are reported (the errors ``v_se`` should describe the
    levels' scatter: ``turnoff.decision_errors``). Brighter-fatter flattening of a
    deep-well CCD's PTC then no longer pulls a straight-line gain (Astier et al. 2019)."""
    from ares.analysis.stats.tails import chi2_sf, f_sf

    s = np.asarray(s, float)
    v = np.asarray(v, float)
    lf = wls_line(s, v, dof, v_se=v_se)
    n = s.size
    line_p = chi2_sf(n - 2, lf.chi2_red * (n - 2)) if n > 2 and math.isfinite(lf.chi2_red) else math.nan
    if n < 5:
        return GainModel("linear", lf, None, line_p, math.nan, math.nan,
                         f"linear: {n} levels are too few to test a curvature term (needs >= 5)")
    af = astier_fit(s, v, dof, v_se=v_se)
    if not (math.isfinite(af.gain_e_per_dn) and af.gain_e_per_dn > 0):
        return GainModel("linear", lf, None, line_p, math.nan, math.nan, "linear: the Astier fit did not converge or its "
                         "parameters are not determined by these levels")
    astier_p = chi2_sf(n - 3, af.chi2_red * (n - 3))
    chi_line, chi_ast = lf.chi2_red * (n - 2), af.chi2_red * (n - 3)
    f = (chi_line - chi_ast) / max(af.chi2_red, 1e-300)
    f_p = f_sf(1, n - 3, f) if f > 0 else 1.0
    a_sig = abs(af.a00) / af.a00_se if af.a00_se > 0 else math.inf
    # by physics (issue 48): a photon-transfer curve bends (brighter-fatter, Astier 2019)
    # and the line is the Astier form's a00 = 0 case. A line over a range bent by an a00
    # too small to detect is still biased, by several of its own SEs over many levels
    # (tests/ptc_corpus.py), while the Astier K's SE carries the curvature's uncertainty;
    # so the Astier fit is the headline wherever the levels determine it, the line only
    # where they do not (fewer than 5 levels, no convergence: above)
    ev = (f"a00 = {af.a00:.3g} ± {af.a00_se:.2g} 1/e-, {a_sig:.2g} SE from 0; curvature F-test p {f_p:.2g}; the "
          f"line's chi2/dof {lf.chi2_red:.3g}, p {line_p:.2g}")
    if a_sig > 2 and f_p < 0.05:
        return GainModel("astier", lf, af, line_p, astier_p, f_p,
                         f"Astier 2019: the curvature term is significant ({ev})")
    return GainModel("astier", lf, af, line_p, astier_p, f_p,
                     f"Astier 2019: the line is its a00 = 0 case, and a curvature too small to detect still biases "
                     f"a line beyond its SE ({ev})")


def bspline_design(x, t, derivative: bool = False) -> np.ndarray:
    """Cubic B-spline basis (or its first derivative) on the clamped knots ``t`` at ``x``
    (inside [t[0], t[-1]], the right end included): the design matrix, (len(x),
    len(t) - 4), by the Cox - de Boor recursion -- what ``scipy.interpolate.BSpline.
    design_matrix`` gives (tested), without importing scipy.interpolate (it brings
    scipy.optimize: 0.4 s)."""
    x = np.asarray(x, float)
    t = np.asarray(t, float)
    k = 3
    last = int(np.nonzero(t[:-1] < t[1:])[0][-1])  # the last non-empty knot interval takes the right end
    B = ((t[:-1] <= x[:, None]) & (x[:, None] < t[1:])).astype(float)
    B[x == t[last + 1], last] = 1.0
    for p in range(1, k + 1):
        left_den = t[p:-1] - t[: -p - 1]
        right_den = t[p + 1:] - t[1:-p]
        with np.errstate(divide="ignore", invalid="ignore"):
            if derivative and p == k:
                a = np.where(left_den > 0, p / left_den, 0.0)
                b = np.where(right_den > 0, p / right_den, 0.0)
                return a * B[:, :-1] - b * B[:, 1:]
            a = np.where(left_den > 0, (x[:, None] - t[: -p - 1]) / left_den, 0.0)
            b = np.where(right_den > 0, (t[p + 1:] - x[:, None]) / right_den, 0.0)
        B = a * B[:, :-1] + b * B[:, 1:]
    return B


@dataclass(frozen=True)
class LocalSlopeCheck:
    """EMVA 1288 4.0 Linear Eq. 51: mean |K_i - K| / K over the fitted levels."""

    mean_rel_dev: float
    holds: bool | None  # None: not testable (too few levels)
    note: str
    intervals: int = 0  # P of the text's B-spline (0: the noise-floor variant's quantile knots)


def local_slope_check_text(s, v, k: float, s_sat: float, limit: float = 0.03,
                           intervals: int | None = None) -> LocalSlopeCheck:
    """Eq. 51 as written (Linear Section 6.6): the General document's cubic B-spline (its
    Eqs. 44 - 47, P equal intervals of width s_sat / P from 0 to the saturation signal
    ``s_sat``, unweighted least squares) fitted to the photon transfer curve ``v`` vs ``s``
    at every level up to saturation; its derivative (Eq. 48) at the levels within 0 - 70 %
    of saturation is K_i; the linear model holds when mean |K_i - K| / K < 3 %. P: 6 - 8
    for ~50 steps, more for more and fewer for fewer (General Section 6.6)."""
    from ares.analysis.stats.splines import bspline_fit, intervals_for

    s = np.asarray(s, float)
    v = np.asarray(v, float)
    use = np.isfinite(s) & np.isfinite(v) & (s <= s_sat)
    s, v = s[use], v[use]
    P = intervals if intervals is not None else intervals_for(s.size)
    inner = s <= 0.7 * s_sat
    if not (math.isfinite(k) and k != 0 and math.isfinite(s_sat) and s_sat > 0) or s.size <= P + 3 or not inner.any():
        return LocalSlopeCheck(math.nan, None, f"needs more than {P + 3} levels up to saturation and a gain "
                                               f"(has {s.size})", P)
    spline = bspline_fit(s, v, P, s_sat)
    ki = spline.slope(s[inner])
    dev = float(np.mean(np.abs(ki - k)) / abs(k))
    verdict = "holds" if dev < limit else "does not hold: use the general model (EMVA 1288 4.0 General)"
    return LocalSlopeCheck(dev, dev < limit, f"Eq. 51 (EMVA 1288 4.0 Linear, as written): mean |K_i - K|/K = "
                                             f"{100 * dev:.2f} % over {int(inner.sum())} levels (cubic B-spline, "
                                             f"{P} equal intervals up to saturation): the linear model {verdict}", P)


def local_slope_check(s, v, v_se, k: float, limit: float = 0.03, errors_name: str = "counts' errors") -> LocalSlopeCheck:
    """ARES's variant of Eq. 51 (option ``eq51_noise_floor``, beyond the text): local slopes ``K_i`` of a weighted cubic B-spline regression of ``V`` vs ``S``
    (interior knots at signal quantiles, one per four levels, at most three: a smoothing
    regression, not an interpolation) at every fitted level, against the fitted ``K``.

    The verdict is decided on the levels' measured scatter (issue 48): the errors ``v_se``
    (from pixel and frame counts; NaN or None where none are known) are checked against the
    residual scatter about a local quadratic (``stats.scatter.measured_scatter``); where
    the two disagree -- or no errors are known -- the measured scatter sets the errors,
    hence the noise floor of the local slopes, and the note says so. ``errors_name`` names
    where ``v_se`` came from (the counts, or the decisions' measured-scatter errors)."""
    from ares.analysis.stats.scatter import measured_scatter

    s = np.asarray(s, float)
    v = np.asarray(v, float)
    n = s.size
    e = np.full(n, math.nan) if v_se is None else np.asarray(v_se, float)
    if n < 5 or not math.isfinite(k) or k == 0:
        return LocalSlopeCheck(math.nan, None, f"needs >= 5 fitted levels and a gain (has {n})")
    o = np.argsort(s)
    s, v, e = s[o], v[o], e[o]
    known = bool(np.all(np.isfinite(e) & (e > 0)))
    if not known:  # a relative scale until the scatter says how large
        e = np.maximum(np.abs(v), 1e-300)
    sc = measured_scatter(s, v, e)
    if sc.available and sc.ratio > 0 and (sc.disagree or not known):
        e = e * sc.ratio
        errs = (f"errors from the measured scatter about a local quadratic ({sc.ratio:.3g} x the "
                + (errors_name if known else "variance") + f", {sc.n} levels)")
    elif sc.available and sc.ratio == 0:  # exact levels: the floor is ~0 and the deviation alone decides
        e = np.maximum(e * 1e-9, 1e-300)
        errs = "the levels lie on a smooth curve to rounding: no scatter to measure"
    elif known:
        errs = (f"errors: the {errors_name}, " + (f"consistent with the measured scatter ({sc.ratio:.3g} ± "
                                               f"{sc.ratio_se:.2g} x, {sc.n} levels)" if sc.available else
                                               f"unchecked: {sc.note}"))
    else:
        return LocalSlopeCheck(math.nan, None, f"no variance errors are known and {n} levels are too few to measure "
                                               "their scatter: see Eq. 51 as written")
    e = np.maximum(e, 1e-300)
    m = min(max((n - 4) // 4, 0), 3)
    inner = list(sorted_quantiles(s, np.linspace(0, 1, m + 2)[1:-1])) if m else []
    t = np.r_[[s[0]] * 4, inner, [s[-1]] * 4]
    A = bspline_design(s, t) / e[:, None]  # weighted least squares
    D = bspline_design(s, t, derivative=True)
    try:
        coef, _, rank, _ = np.linalg.lstsq(A, v / e, rcond=None)
    except np.linalg.LinAlgError as exc:
        return LocalSlopeCheck(math.nan, None, f"B-spline regression failed ({exc})")
    if rank < A.shape[1]:
        return LocalSlopeCheck(math.nan, None, "B-spline regression failed (too few distinct levels between the knots)")
    ki = D @ coef
    dev = float(np.mean(np.abs(ki - k)) / abs(k))
    # the noise floor: the distribution of mean |K_i - K| / K a perfectly linear curve gives
    # with these error bars. The regression is linear in v and a line lies in the spline
    # space, so under the linear model K_i - K = D A^+ z with z ~ N(0, 1) per level (v / e
    # units): 4000 draws of z (a fixed seed: the verdict is a function of the data) give the
    # floor (their mean) and the chance p of a deviation as large as this one by noise alone.
    M = D @ np.linalg.pinv(A)
    z = np.random.default_rng(20480).standard_normal((M.shape[1], 4000))
    null = np.mean(np.abs(M @ z), axis=0) / abs(k)
    floor = float(np.mean(null))
    p_noise = float((np.count_nonzero(null >= dev) + 1) / (null.size + 1))
    # the bend's size: the noise adds to it in quadrature, as rms values do (a linear
    # subtraction would let a noise floor half the size of a real bend hide it); it decides
    # only where the deviation is beyond the noise (p < 1 %): near the floor, quadrature
    # turns the floor's own scatter into a large "excess" (floor 3 %, noise 4 %: 2.6 %)
    excess = math.sqrt(max(dev * dev - floor * floor, 0.0)) if math.isfinite(floor) else dev
    if excess >= limit and p_noise >= 0.01:
        return LocalSlopeCheck(dev, True, f"linear model holds: mean |K_i - K|/K = {100 * dev:.2g} % is within the "
                                          f"noise of the local slopes (a linear curve with these errors gives as much "
                                          f"with p = {p_noise:.2g}; floor {100 * floor:.2g} %) (ARES option "
                                          f"eq51_noise_floor, beyond EMVA 1288 4.0 Linear Eq. 51; {errs})")
    if dev < limit:
        return LocalSlopeCheck(dev, True, f"linear model holds: mean |K_i - K|/K = {100 * dev:.2g} % "
                                          f"< {100 * limit:g} % (ARES's variant of EMVA 1288 4.0 Linear Eq. 51, "
                                          f"option eq51_noise_floor; {errs})")
    if excess < limit and math.isfinite(floor):
        return LocalSlopeCheck(dev, True, f"linear model holds: mean |K_i - K|/K = {100 * dev:.2g} %, of which "
                                          f"{100 * floor:.2g} % is the noise of the local slopes; the excess "
                                          f"{100 * excess:.2g} % < {100 * limit:g} % (ARES option eq51_noise_floor, "
                                          f"beyond EMVA 1288 4.0 Linear Eq. 51: noise floor removed; {errs})")
    return LocalSlopeCheck(dev, False, f"the linear model does not hold here: mean |K_i - K|/K = {100 * dev:.2g} % "
                                       f">= {100 * limit:g} % (ARES's variant of EMVA 1288 4.0 Linear Eq. 51, option "
                                       f"eq51_noise_floor; {errs}); use the general model")


def deviation_se(x, y, y_se, k: int) -> float:
    """SE (in %) of level ``k``'s relative deviation ``100 (y_k - f_k) / f_k`` from the line
    ``f = a x + b`` fitted with weights 1/y, from each level's signal SE ``y_se`` (DN): the fit
    is ``f = H y`` (hat matrix, weights held fixed), so by the delta method
    ``d dev_k / d y_j = 100 (delta_kj / f_k - H_kj y_k / f_k^2)``."""
    x, y, y_se = (np.asarray(a, float) for a in (x, y, y_se))
    A = np.column_stack([x, np.ones_like(x)])
    w2 = 1.0 / (y * y)
    H = A @ np.linalg.solve(A.T @ (A * w2[:, None]), (A * w2[:, None]).T)
    f = H @ y
    g = -100.0 * H[k] * y[k] / (f[k] * f[k])
    g[k] += 100.0 / f[k]
    return float(math.sqrt(np.sum((g * y_se) ** 2)))


def max_relative_deviation(x, y, y_se) -> tuple[float, float, np.ndarray]:
    """(max |dev| in %, its SE in %, dev in %): ``dev = 100 (y - f) / f`` from the line
    ``f = a x + b`` fitted with weights 1/y (minimising relative deviations, as EMVA 1288);
    the SE is ``deviation_se`` at the level where |dev| is largest. (A max over levels is
    biased up by noise; its SE is that of the extreme level only.)"""
    x, y = np.asarray(x, float), np.asarray(y, float)
    a, b = np.polyfit(x, y, 1, w=1.0 / y)
    dev = 100.0 * (y - (a * x + b)) / (a * x + b)
    k = int(np.argmax(np.abs(dev)))
    return float(abs(dev[k])), deviation_se(x, y, y_se, k), dev


RUNS_P = 1e-3  # a line whose residuals' signs run this improbably long does not follow the levels


def runs_p(residuals) -> float:
    """Wald-Wolfowitz runs test on the signs of ``residuals`` in their order: the one-sided
    probability of as few runs as seen or fewer if the signs were in random order (normal
    approximation). Needs no errors: a curve the fitted model does not follow (a plateau, a
    turnover, a bend) leaves long runs of one sign. 1.0 where it cannot tell (< 2 of a sign)."""
    r = np.asarray(residuals, float)
    r = r[np.isfinite(r) & (r != 0)]
    pos = r > 0
    n1, n2 = int(pos.sum()), int((~pos).sum())
    n = n1 + n2
    if n1 < 2 or n2 < 2:
        return 1.0
    runs = 1 + int(np.count_nonzero(pos[1:] != pos[:-1]))
    mean = 2.0 * n1 * n2 / n + 1
    var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / (n * n * (n - 1))
    return 0.5 * math.erfc(-((runs - mean) / math.sqrt(var)) / math.sqrt(2)) if var > 0 else 1.0
