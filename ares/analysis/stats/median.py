"""Order statistics without ``numpy.ma`` (``np.median``, ``np.quantile`` and ``np.unique``
import it on first use: 12 ms of ``ares emva``), the same results as numpy's (tested)."""

from __future__ import annotations

import numpy as np


def fast_median(a: np.ndarray, axis: int | None = None) -> np.ndarray | float:
    """``np.median`` (no NaN handling) with one partition instead of two: for an even count
    the lower middle value is the maximum of the lower partition. 2-5x faster."""
    a = np.asarray(a)
    if axis is None:
        a, axis = a.ravel(), 0
    n = a.shape[axis]
    k = n // 2
    p = np.partition(a, k, axis=axis)
    hi = np.take(p, k, axis=axis)
    if n % 2:
        return hi.astype(np.float64)
    lo = np.take(p, np.arange(k), axis=axis).max(axis=axis)
    return (lo.astype(np.float64) + hi) / 2.0


def sorted_quantiles(s: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``np.quantile(s, q)`` (its default linear method) of an ascending ``s``."""
    pos = np.asarray(q, float) * (s.size - 1)
    lo = np.floor(pos).astype(np.intp)
    t = pos - lo
    a, b = s[lo], s[np.minimum(lo + 1, s.size - 1)]
    d = b - a
    return np.where(t >= 0.5, b - d * (1 - t), a + d * t)  # numpy's two-sided lerp


def n_distinct(values) -> int:
    """``np.unique(values).size`` of a 1-D sequence of numbers (exposure times, a few dozen)."""
    return len(set(np.asarray(values, float).ravel().tolist()))
