"""EMVA 1288-style logarithmic and accumulated histograms of per-pixel deviations.

EMVA 1288 (Release 4.0, defect pixel characterization) shows the spatial deviations of
the dark signal and of the response as a histogram on a logarithmic count axis, and as
an *accumulated* histogram: the percentage of pixels whose absolute deviation from the
mean is at least x. Users read their own stop bands off the accumulated curve; the
arrays here are what a report plots.
"""

from __future__ import annotations

import numpy as np


def deviation_histograms(deviation: np.ndarray, unit: str, bins: int = 256) -> dict:
    """Histogram and accumulated histogram of ``deviation`` (pixel minus typical pixel)."""
    d = np.asarray(deviation, dtype=np.float64).ravel()
    d = d[np.isfinite(d)]
    if d.size == 0:
        return {"unit": unit, "n_pixels": 0, "edges": [], "counts": [], "abs_edges": [], "accumulated_percent": []}
    lo, hi = float(d.min()), float(d.max())
    if hi <= lo:
        hi = lo + 1.0
    counts, edges = np.histogram(d, bins=bins, range=(lo, hi))
    a = np.abs(d)
    amax = float(a.max()) if a.max() > 0 else 1.0
    abs_edges = np.linspace(0.0, amax, bins + 1)
    # percentage of pixels with |deviation| >= x, for each x in abs_edges: all pixels minus
    # those in the bins below x (bins are [e_i, e_i+1), the last one closed)
    below, _ = np.histogram(a, bins=abs_edges)
    at_least = a.size - np.concatenate([[0], np.cumsum(below)])
    at_least[-1] = np.count_nonzero(a >= amax)
    accumulated = 100.0 * at_least / a.size
    return {"unit": unit, "n_pixels": int(d.size), "edges": edges, "counts": counts,
            "abs_edges": abs_edges, "accumulated_percent": accumulated}
