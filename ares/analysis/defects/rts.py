"""Random telegraph signal ("flashing", bistable) pixels from candidate time series.

Pass 2 of the two-pass scheme: pass 1 flags noisy pixels from per-pixel variance; here
each candidate's series is split into two levels by the exact 1-D two-means (Otsu)
split -- the threshold minimizing the within-level sum of squares -- and called RTS when

* each level holds at least ``min_occupancy`` of the frames (a single outlier, e.g. a
  cosmic-ray hit, is not a level), and
* the level separation is at least ``min_separation`` times the within-level noise
  sigma_w (the pixel's own temporal noise without the telegraph term).

A Gaussian series of 100 frames gives a separation of about 2.7 sigma_w (the two halves
of a normal distribution), so the default 4.0 leaves a wide margin against noisy pixels
while an RTS of amplitude >= 5x the temporal noise splits cleanly.
"""

from __future__ import annotations

import math

import numpy as np


def two_level_split(series: np.ndarray, min_occupancy: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Best two-level split of each column of ``series`` (F, n).

    Returns (separation in sigma_w, amplitude DN, sigma_w DN, fraction in the upper level).
    """
    x = np.sort(np.asarray(series, dtype=np.float64), axis=0)
    f, n = x.shape
    if n == 0:
        e = np.empty(0)
        return e, e, e, e
    x = x - x[:1]  # shift for numerical safety
    kmin = max(2, int(math.ceil(min_occupancy * f)))
    if f - kmin < kmin:
        nan = np.full(n, np.nan)
        return nan, nan, nan, nan
    s1 = np.cumsum(x, axis=0)
    s2 = np.cumsum(x * x, axis=0)
    t1, t2 = s1[-1], s2[-1]
    k = np.arange(kmin, f - kmin + 1)[:, None]  # size of the lower level
    l1, l2 = s1[k[:, 0] - 1], s2[k[:, 0] - 1]
    ss = (l2 - l1 * l1 / k) + ((t2 - l2) - (t1 - l1) ** 2 / (f - k))
    best = np.argmin(ss, axis=0)
    cols = np.arange(n)
    kb = k[best, 0]
    lo = l1[best, cols] / kb
    hi = (t1 - l1[best, cols]) / (f - kb)
    sw = np.sqrt(np.maximum(ss[best, cols], 0.0) / (f - 2))
    amp = hi - lo
    with np.errstate(divide="ignore", invalid="ignore"):
        sep = np.where(sw > 0, amp / sw, np.where(amp > 0, np.inf, 0.0))
    return sep, amp, sw, (f - kb) / f


def detect_rts(series: np.ndarray, min_separation: float, min_occupancy: float) -> tuple[np.ndarray, np.ndarray]:
    """(is_rts, separation) for each column of ``series`` (F, n)."""
    sep, _amp, _sw, _p = two_level_split(series, min_occupancy)
    return np.nan_to_num(sep, nan=0.0) >= min_separation, sep
