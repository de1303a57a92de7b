"""The scatter a series of measurements actually shows, against the scatter its errors claim.

Decisions taken on standard errors (a turnoff "> 4 SE below the curve", a chi-square test
choosing a model) are only as good as those errors. Errors computed from pixel and frame
counts assume Gaussian, independent samples; a table without counts has none at all. This
module measures the scatter of ``y`` about a smooth local fit and compares it with the
claimed errors:

- ``local_residuals``: each point's residual from the least-squares quadratic through its
  four nearest neighbours in ``x`` (two on each side where they exist), with the residual's
  variance factor ``1 + sum w^2`` (the local fit's own noise; ``w`` its linear-smoother
  weights). A quadratic follows a photon-transfer curve's brighter-fatter bend exactly, so
  only the noise (and a sharp corner such as a turnoff, a few points) is left.
- ``measured_scatter``: the robust (MAD) scale of those residuals in units of the claimed
  errors -- ``ratio`` 1 when the errors describe the data -- with its own SE, and the
  verdict whether the two disagree (``disagree``) beyond that SE; ``local_z``: each point's
  residual in units of its claimed error (an outlier row is one far out: ``ptc.headline``).

Linear in the number of points (vectorised 3x3 solves). Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.median import fast_median

MAD_TO_SIGMA = 1.4826  # sigma = 1.4826 MAD for a normal distribution
MIN_POINTS = 6  # fewer points than this: no measured scatter (the local fit needs 4 neighbours)


def _neighbours(n: int) -> np.ndarray:
    """(n, 4) indices of each point's four nearest neighbours by position: two each side,
    shifted inwards at the ends."""
    i = np.arange(n)[:, None]
    lo = np.clip(np.arange(n) - 2, 0, n - 5)[:, None]  # a window of 5 positions containing i
    win = lo + np.arange(5)[None, :]
    nb = np.where(win == i, -1, win)
    return np.sort(nb, axis=1)[:, 1:]  # drop the -1 (i itself)


def local_residuals(x, y) -> tuple[np.ndarray, np.ndarray]:
    """(residual of each ``y`` from the quadratic through its 4 neighbours, the residual's
    variance factor ``1 + sum w^2`` for equal errors). ``x`` must be sorted; needs >= 5
    points (else empty arrays). Neighbours sharing one ``x`` value (duplicated rows) fall
    back to the pseudo-inverse's minimum-norm fit (a line or a constant)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    n = x.size
    if n < 5:
        return np.empty(0), np.empty(0)
    nb = _neighbours(n)
    span = np.ptp(x[nb], axis=1)[:, None]
    span = np.where(span > 0, span, 1.0)
    u = (x[nb] - x[:, None]) / span  # centred on the point, scaled to the window
    X = np.stack([np.ones_like(u), u, u * u], axis=2)  # (n, 4, 3)
    H = np.linalg.pinv(X)  # (n, 3, 4): the least-squares solution operator
    w = H[:, 0, :]  # the fit's value at the point (u = 0) as weights on the neighbours
    pred = np.einsum("ij,ij->i", w, y[nb])
    return y - pred, 1.0 + np.einsum("ij,ij->i", w, w)


def local_z(x, y, e) -> np.ndarray:
    """Each point's ``local_residuals`` residual in units of its claimed error -- the point's
    own and its neighbours' (the local fit's noise, weights ~ equal). ``x`` sorted, >= 5 points."""
    e = np.asarray(e, float)
    r, f = local_residuals(x, y)
    nb = _neighbours(e.size)
    return r / np.sqrt(e * e + (f - 1.0) * np.mean(e[nb] ** 2, axis=1))


@dataclass(frozen=True)
class Scatter:
    """Measured scatter in units of the claimed errors."""

    ratio: float  # robust rms of (residual / claimed error); 1: the errors describe the data
    ratio_se: float  # its standard error (relative: ~1.17 / sqrt(n) for a MAD)
    n: int  # points behind it
    disagree: bool  # the ratio differs from 1 beyond its own noise and a factor ``tolerance``
    note: str

    @property
    def available(self) -> bool:
        return math.isfinite(self.ratio)


def measured_scatter(x, y, y_err, tolerance: float = 1.5, nsigma: float = 3.0) -> Scatter:
    """The scatter of ``y`` (sorted by ``x``) about its local quadratic, in units of the
    claimed errors ``y_err`` (any positive scale when no errors are known: then ``ratio`` is
    the scatter in that unit). ``disagree``: the ratio lies outside ``[1/t, t]`` with ``t =
    max(tolerance, 1 + nsigma * SE)`` -- a factor the MAD of these points can tell apart
    from 1."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    e = np.asarray(y_err, float)
    ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(e) & (e > 0)
    x, y, e = x[ok], y[ok], e[ok]
    n = x.size
    if n < MIN_POINTS:
        return Scatter(math.nan, math.nan, n, False, f"{n} points: too few to measure their scatter "
                                                     f"(needs >= {MIN_POINTS})")
    o = np.argsort(x, kind="stable")
    z = local_z(x[o], y[o], e[o])
    med = float(fast_median(z))
    ratio = MAD_TO_SIGMA * float(fast_median(np.abs(z - med)))
    se = 1.17 * ratio / math.sqrt(n)
    t = max(tolerance, 1.0 + nsigma * 1.17 / math.sqrt(n))
    if not ratio > 0:
        return Scatter(0.0, 0.0, n, True, f"the {n} points lie on a smooth curve to rounding: no scatter to measure")
    disagree = not (1.0 / t <= ratio <= t)
    note = (f"measured scatter about a local quadratic (MAD of {n} points) is {ratio:.3g} ± {se:.2g} times the "
            f"claimed errors")
    return Scatter(ratio, se, n, disagree, note)
