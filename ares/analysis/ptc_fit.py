"""Photon-transfer fits of temporal variance ``V`` against signal ``S`` (both in DN).

- ``origin_fit``: ordinary least squares through the origin (EMVA 1288 ``K``).
- ``wls_line``: weighted least squares ``V = K*S + c`` with ``var(V) ~ 2 V^2 / N``
  (``N`` degrees of freedom of each variance), optionally through the origin.
- ``astier_fit``: Astier et al. 2019 (arXiv:1905.08677) eq. 16 restricted to C00,
  ``V = (exp(2 a00 S g) - 1) / (2 a00 g^2) + n00 / g^2`` with ``g`` in e-/DN;
  ``a00 -> 0`` gives the line ``V = S/g + n00/g^2``.

Every fit returns a ``LineFit``/``AstierFit`` with standard errors; the covariance is
scaled by the reduced chi-square when that exceeds one (model scatter beyond the
Gaussian error model is never hidden).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import curve_fit


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
    cov = np.linalg.inv(Aw.T @ Aw) * max(chi2, 1.0)
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
    with np.errstate(divide="ignore", invalid="ignore"):
        lin = np.where(np.abs(x) < 1e-8, mu / g * (1.0 + x / 2.0), np.expm1(x) / (2.0 * a00 * g * g))
    return lin + n00 / (g * g)


def astier_fit(s, v, dof) -> AstierFit:
    """Fit the exponential approximation with weights ``N / (2 V^2)``."""
    s = np.asarray(s, float)
    v = np.asarray(v, float)
    dof = np.broadcast_to(np.asarray(dof, float), s.shape)
    if s.size < 4:
        nan = math.nan
        return AstierFit(nan, nan, nan, nan, nan, nan, nan, s.size)
    sig = np.sqrt(2.0 / dof) * np.maximum(np.abs(v), 1e-12)
    lf = wls_line(s, v, dof)
    g0 = 1.0 / lf.slope if lf.slope > 0 else 1.0
    p0 = [0.0, g0, lf.intercept * g0 * g0]
    try:
        popt, pcov = curve_fit(astier_model, s, v, p0=p0, sigma=sig, absolute_sigma=True, maxfev=20000)
    except (RuntimeError, ValueError):
        nan = math.nan
        return AstierFit(nan, nan, nan, nan, nan, nan, nan, s.size)
    r = (v - astier_model(s, *popt)) / sig
    chi2 = float(r @ r) / max(s.size - 3, 1)
    pcov = pcov * max(chi2, 1.0)
    se = np.sqrt(np.diag(pcov))
    return AstierFit(float(popt[1]), float(se[1]), float(popt[0]), float(se[0]), float(popt[2]),
                     float(se[2]), chi2, s.size)
