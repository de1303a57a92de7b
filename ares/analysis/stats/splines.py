"""Least-squares cubic B-splines (EMVA 1288 4.0 General Eqs. 44 - 49): the characteristic curve
of ``emva.general`` and the smooth reference of the PTC's local checks (``ptc.fit``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def beta3(x: np.ndarray) -> np.ndarray:
    """Cubic B-spline (General Eq. 45)."""
    a = np.abs(np.asarray(x, float))
    return np.where(a < 1, 2 / 3 - a**2 + 0.5 * a**3, np.where(a <= 2, (2 - a) ** 3 / 6, 0.0))


def beta3_prime(x: np.ndarray) -> np.ndarray:
    """Its derivative (General Eq. 49)."""
    x = np.asarray(x, float)
    a = np.abs(x)
    return np.where(a < 1, -2 * x * (1 - 0.75 * a), np.where(a <= 2, -np.sign(x) * 0.5 * (2 - a) ** 2, 0.0))


@dataclass
class BSpline:
    """Least-squares cubic B-spline on [0, x_max] with P intervals (Eqs. 44 - 48)."""

    x_max: float
    P: int
    coef: np.ndarray
    cov: np.ndarray  # coefficient covariance from the residual scatter
    rms: float  # residual RMS

    def _basis(self, x, fn):
        d = self.x_max / self.P
        u = np.asarray(x, float)[..., None] / d - (np.arange(self.P + 3) - 1)  # Eq. 46: beta3(x/d - (p-1))
        return fn(u)

    def __call__(self, x) -> np.ndarray:
        return self._basis(x, beta3) @ self.coef

    def slope(self, x) -> np.ndarray:
        return self._basis(x, beta3_prime) @ self.coef / (self.x_max / self.P)  # Eq. 48

    def se(self, x, derivative: bool = False) -> np.ndarray:
        B = self._basis(x, beta3_prime if derivative else beta3)
        if derivative:
            B = B / (self.x_max / self.P)
        return np.sqrt(np.einsum("...i,ij,...j->...", B, self.cov, B))


def bspline_fit(x, y, P: int, x_max: float | None = None) -> BSpline:
    """Eq. 47 solved by linear least squares; needs more points than P + 3. Each point
    touches 4 of the P + 3 basis functions, so the normal equations are summed from those
    4 per point (linear in the points, no dense design matrix) and solved once."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    xm = float(x_max if x_max is not None else x.max())
    if x.size <= P + 3:
        raise ValueError(f"a B-spline with {P} intervals needs more than {P + 3} points, has {x.size}")
    d = xm / P
    m = P + 3
    t = x / d
    first = np.clip(np.floor(t).astype(np.int64), 0, m - 4)  # basis p is non-zero for p - 3 < t < p + 1
    cols = first[:, None] + np.arange(4)[None, :]
    B = beta3(t[:, None] - (cols - 1))  # (n, 4) values of the 4 bases that can be non-zero
    AtA = np.zeros((m, m))
    np.add.at(AtA, (cols[:, :, None], cols[:, None, :]), B[:, :, None] * B[:, None, :])
    Aty = np.bincount(cols.ravel(), (B * y[:, None]).ravel(), minlength=m)
    coef = np.linalg.lstsq(AtA, Aty, rcond=None)[0]
    r = y - np.einsum("ij,ij->i", B, coef[cols])
    dof = x.size - m
    s2 = float(r @ r) / dof
    cov = s2 * np.linalg.pinv(AtA)
    return BSpline(xm, P, coef, cov, math.sqrt(s2))


MAX_INTERVALS = 128  # more intervals than this fit the noise of a dense table, and cost P^3


def intervals_for(n_points: int) -> int:
    """P: 6 - 8 intervals for ~50 exposure steps (Section 6.6), more for more steps, fewer
    for few, at most ``MAX_INTERVALS`` (a table of 1000+ levels); always fewer parameters
    than points."""
    return int(max(2, min(max(6, n_points // 8), n_points - 5, MAX_INTERVALS)))
