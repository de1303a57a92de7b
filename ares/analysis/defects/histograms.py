"""EMVA 1288-style logarithmic and accumulated histograms of per-pixel deviations.

EMVA 1288 (Release 4.0, defect pixel characterization) shows the spatial deviations of
the dark signal and of the response as a histogram on a logarithmic count axis, and as
an *accumulated* histogram: the percentage of pixels whose absolute deviation from the
mean is at least x. Users read their own stop bands off the accumulated curve; the
arrays here are what a report plots.
"""

from __future__ import annotations

import numpy as np

_BLOCK = 1 << 20  # values at a time for the accumulated histogram


def deviation_histograms(deviation: np.ndarray, unit: str, bins: int = 256) -> dict:
    """Histogram and accumulated histogram of ``deviation`` (pixel minus typical pixel)."""
    d = np.asarray(deviation, dtype=np.float64).ravel()
    finite = np.isfinite(d)
    if not finite.all():
        d = d[finite]
    del finite
    if d.size == 0:
        return {"unit": unit, "n_pixels": 0, "edges": [], "counts": [], "abs_edges": [], "accumulated_percent": []}
    lo, hi = float(d.min()), float(d.max())
    amax = max(abs(lo), abs(hi)) or 1.0
    if hi <= lo:
        hi = lo + 1.0
    counts, edges = np.histogram(d, bins=bins, range=(lo, hi))
    abs_edges = np.linspace(0.0, amax, bins + 1)
    # percentage of pixels with |deviation| >= x, for each x in abs_edges: all pixels minus
    # those in the bins below x (bins are [e_i, e_i+1), the last one closed). |d| a block at
    # a time: the same counts without a frame of float64 (a 4096x3072 map: 96 MiB)
    below = np.zeros(bins, np.int64)
    top = 0
    for i in range(0, d.size, _BLOCK):
        a = np.abs(d[i: i + _BLOCK])
        below += np.histogram(a, bins=abs_edges)[0]
        top += int(np.count_nonzero(a >= amax))
    at_least = d.size - np.concatenate([[0], np.cumsum(below)])
    at_least[-1] = top
    accumulated = 100.0 * at_least / d.size
    return {"unit": unit, "n_pixels": int(d.size), "edges": edges, "counts": counts,
            "abs_edges": abs_edges, "accumulated_percent": accumulated}
