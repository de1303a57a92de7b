"""The median without numpy's extras: one partition instead of two, and no ``numpy.ma``
(``np.median`` and ``np.quantile`` import it on first use: 12 ms of ``ares emva``)."""

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
