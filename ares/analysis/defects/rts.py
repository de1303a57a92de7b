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

import functools
import math

import numpy as np
from scipy import special


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


#: series drawn for the Gaussian null distribution of the separation (fixed seed)
NULL_SERIES = 200_000
NULL_MAX_FRAMES = 128  # above this the null quantile of 128 frames is used (it falls with F: conservative)


@functools.lru_cache(maxsize=16)
def _separation_null(f: int, min_occupancy: float, n: int) -> np.ndarray:
    """The sorted separations of ``n`` standard normal series of ``f`` frames (fixed seed);
    an empty array where no split with ``min_occupancy`` exists. Shared by every p."""
    rng = np.random.default_rng(20261128 + f)
    seps = []
    for i in range(0, n, 20_000):
        s, *_ = two_level_split(rng.standard_normal((f, min(20_000, n - i))), min_occupancy)
        if np.all(np.isnan(s)):
            return np.empty(0)
        seps.append(s)
    return np.sort(np.concatenate(seps))


def _null_size(f: int, p_fa: float) -> int:
    return max(NULL_SERIES // max(f // 16, 1), int(50 / p_fa))


def null_separation(frames: int, min_occupancy: float, p_fa: float) -> float:
    """Separation a Gaussian (single-level) series of ``frames`` frames exceeds with
    probability ``p_fa``: the two-means split of a few frames always finds *some* gap (the
    two most extreme of 16 frames sit ~5 sigma_w from the rest), so a fixed separation
    threshold turns hot and noisy pixels into RTS at low frame counts. The statistic is
    scale- and offset-free (amp / sigma_w), so one Monte Carlo of standard normals with a
    fixed seed serves every pixel; inf where no split with ``min_occupancy`` exists."""
    f = min(int(frames), NULL_MAX_FRAMES)
    null = _separation_null(f, float(min_occupancy), _null_size(f, p_fa))
    return float(np.quantile(null, 1.0 - p_fa)) if null.size else math.inf


def rts_threshold(frames: int, min_separation: float, min_occupancy: float, p_fa: float) -> float:
    """The separation an RTS pixel must show at this frame count: the configured minimum
    or the Gaussian null's (1 - p_fa) quantile, whichever is larger."""
    return max(float(min_separation), null_separation(int(frames), float(min_occupancy), float(p_fa)))


def lag1_autocorrelation(series: np.ndarray) -> np.ndarray:
    """Lag-1 autocorrelation of each column of ``series`` (F, n) in frame order:
    sum (x_t - m)(x_t+1 - m) / sum (x_t - m)^2; 0 for a constant column.

    A telegraph pixel's levels persist from frame to frame (a trap that flips with
    probability p per frame has a telegraph autocorrelation 1 - 2p at lag 1), so its series
    is not white; a noisy pixel's excess read noise is (about -1/F). Unlike the two-level
    split this needs no resolved levels: it tells a trap whose amplitude is a few times the
    temporal noise from a noisy pixel by the time order alone."""
    x = np.asarray(series, dtype=np.float64)
    if x.shape[0] < 3 or x.shape[1] == 0:
        return np.zeros(x.shape[1] if x.ndim == 2 else 0)
    x = x - x.mean(axis=0)
    den = np.einsum("ij,ij->j", x, x)
    num = np.einsum("ij,ij->j", x[:-1], x[1:])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, 0.0)


@functools.lru_cache(maxsize=16)
def _autocorrelation_null(f: int) -> np.ndarray:
    """Sorted lag-1 autocorrelations of standard normal series of ``f`` frames (fixed seed)."""
    rng = np.random.default_rng(20261207 + f)
    n = NULL_SERIES // max(f // 16, 1)
    return np.sort(np.concatenate([lag1_autocorrelation(rng.standard_normal((f, min(20_000, n - i))))
                                   for i in range(0, n, 20_000)]))


def _upper_p(null: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Empirical upper-tail p-value of each ``x`` against the sorted ``null`` (>= 1/size)."""
    return np.maximum(1.0 - np.searchsorted(null, x, side="left") / null.size, 1.0 / null.size)


def telegraph_evidence(series: np.ndarray, min_occupancy: float, p_fa: float) -> np.ndarray:
    """Fisher's combination -2 (ln p_split + ln p_lag1) of the two signs of a telegraph in a
    pixel's series, each p against a white Gaussian series of as many frames (fixed-seed
    Monte Carlo): its values fall into two levels (the two-means split, order-free) and
    its levels persist from frame to frame (the lag-1 autocorrelation, order only). Under
    the null the split is permutation-invariant and the autocorrelation a permutation
    statistic, so the two are independent and the sum is chi-square with 4 dof; the
    caller compares it with that distribution's (1 - p) quantile. One test of both: a trap
    whose levels overlap (amplitude ~3 sigma_w) shows each only weakly, but both together.
    ``p_fa`` sets the Monte Carlo size (50 / p_fa series at least)."""
    f = min(series.shape[0], NULL_MAX_FRAMES)
    sep, *_ = two_level_split(series, min_occupancy)
    ns = _separation_null(f, float(min_occupancy), _null_size(f, p_fa))
    if not ns.size:
        return np.zeros(series.shape[1])
    nr = _autocorrelation_null(f)
    return -2.0 * (np.log(_upper_p(ns, np.nan_to_num(sep, nan=-np.inf)))
                   + np.log(_upper_p(nr, lag1_autocorrelation(series))))


def low_outlier(series: np.ndarray) -> np.ndarray:
    """Grubbs' statistic of each column's lowest frame: (mean - min) / sample SD. A dark
    pixel's steady excess (a hot or warm pixel's dark current, Poisson and white) does not
    drop far below its own level in one frame; a telegraph trap held high that fell back for
    a frame does (and a cosmic ray only adds charge). 0 for a constant column."""
    x = np.asarray(series, dtype=np.float64)
    if x.shape[0] < 3 or x.shape[1] == 0:
        return np.zeros(x.shape[1] if x.ndim == 2 else 0)
    sd = x.std(axis=0, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sd > 0, (x.mean(axis=0) - x.min(axis=0)) / sd, 0.0)


def low_outlier_critical(frames: int, p_fa: float) -> float:
    """The one-sided Grubbs critical value: a Gaussian series of ``frames`` frames has its
    lowest frame this far below its mean (in sample SDs) with probability <= ``p_fa``
    (Grubbs 1969, the Bonferroni bound through Student's t with F - 2 dof; tight at small
    p). Closed form: no Monte Carlo."""
    f = int(frames)
    if f < 3:
        return math.inf
    t = float(special.stdtrit(f - 2, 1.0 - p_fa / f))
    return (f - 1) / math.sqrt(f) * math.sqrt(t * t / (f - 2 + t * t))
