"""Defective columns and rows.

A line (column or row) is bad when it holds >= ``line_hot_count`` hot/warm pixels or
>= ``line_dead_count`` dead/low-response/stuck pixels, or when its median dark offset or
median response ratio lies more than ``line_z`` robust sigmas from the other lines, or
its median temporal variance is > ``line_z`` robust sigmas and > ``line_noise_factor``
times the expected one. The robust sigma is floored by the
scatter a line median has from pixel noise alone (1.2533 * sigma_pixel / sqrt(n)), so a
perfectly uniform sensor does not turn every tiny offset into a bad line. Line statistics
are compared with a running median of their neighbours (9 lines), so only line-to-line
steps count, not smooth trends.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter

from ares.analysis.defects.robust import robust_sigma


def line_z(values: np.ndarray, pixel_sigma: float, n_per_line: int, detrend: int = 9) -> np.ndarray:
    """Robust z-scores of per-line statistics, after removing a running median over
    ``detrend`` neighbouring lines (so smooth trends -- illumination fall-off, a dark
    gradient -- are not mistaken for bad lines)."""
    v = np.asarray(values, dtype=np.float64)
    v = np.where(np.isfinite(v), v, np.nanmedian(v) if np.isfinite(v).any() else 0.0)
    if detrend > 1 and v.size > detrend:
        v = v - median_filter(v, size=detrend, mode="nearest")
    floor = 1.2533 * pixel_sigma / np.sqrt(max(n_per_line, 1)) if np.isfinite(pixel_sigma) else 0.0
    s = robust_sigma(v, floor=max(floor, 1e-12))
    return (v - np.median(v)) / s


class LineFlags:
    """Collects, per line, whether it is bad and the first statistic that said so."""

    def __init__(self, n: int) -> None:
        self.bad = np.zeros(n, dtype=bool)
        self.reason = np.full(n, "", dtype=object)
        self.value = np.full(n, np.nan)

    def add(self, flags: np.ndarray, reason: str, values: np.ndarray) -> None:
        new = flags & ~self.bad
        self.reason[new] = reason
        self.value[new] = np.asarray(values, dtype=np.float64)[new]
        self.bad |= flags

    def records(self) -> list[dict]:
        return [{"index": int(i), "reason": str(self.reason[i]), "statistic": float(self.value[i])}
                for i in np.flatnonzero(self.bad)]
