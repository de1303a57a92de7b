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

A trap whose levels overlap (amplitude ~1-4 sigma_w) or that sits in one level most of the
time does not split cleanly; ``telegraph_lr`` tests it by the likelihood ratio of a
two-state hidden Markov model (levels that persist from frame to frame) against one
Gaussian, against a measured null of white series (``HMM_NULL``). Against the earlier
Fisher combination of the split and the lag-1 autocorrelation (each against its own
Monte Carlo) it finds more of the traps at equal false-alarm rate: at 64 frames, p = 1e-3,
a 3 sigma_w trap with dwell 33 (low) / 3 frames (high) 40 % against 26 %, switching every
other frame 19 % against 12 %, dwell 20 / 20 frames 90 % against 84 %.
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
    """(is_rts, separation) for each column of ``series`` (F, n). The within-level noise has a
    floor of the quantization noise step^2 / 12 (``quantization_step``): a quiet pixel's
    series on three or four codes splits between two codes with levels sharper than its
    noise (white noise of 0.5 DN reached separations > 4 at 256 frames), a trap's levels
    several codes apart keep theirs."""
    _sep, amp, sw, _p = two_level_split(series, min_occupancy)
    q = quantization_step(series)
    q = np.where(np.isfinite(q), q, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        swq = np.sqrt(sw * sw + q * q / 12.0)
        sep = np.where(swq > 0, amp / swq, np.where(amp > 0, np.inf, 0.0))
    sep = np.where(np.isnan(amp), np.nan, sep)
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


#: Baum-Welch iterations of the telegraph likelihood ratio (fixed: the statistic is this
#: procedure, and the null table below was made with it)
HMM_ITERS = 10
#: frames of the longest null: a longer series is tested on its first HMM_MAX_FRAMES frames
HMM_MAX_FRAMES = 256


def telegraph_lr(series: np.ndarray) -> np.ndarray:
    """Likelihood ratio 2 (ln L_2 - ln L_1) of a two-state Gaussian hidden Markov model (two
    levels, one within-level sigma, Markov switching: a trap's telegraph) against one
    Gaussian, per column of ``series`` (F, n), by ``HMM_ITERS`` Baum-Welch iterations
    (``ares.analysis.kernels.hmm``, the kernel of ``ares rtn``) started at the series'
    two-means split. The series is first standardized (its mean and SD): the statistic is
    offset- and scale-free, so one null of standard normal series serves every pixel, and
    under that null it is independent of the sample variance (Basu) -- the test on top of a
    variance test keeps its own false-alarm rate. Over ``HMM_MAX_FRAMES`` the first that many
    frames. NaN where the series is on too few codes for it (``HMM_MIN_SW_STEPS``). Without
    numba the numpy path of the same Baum-Welch."""
    from ares.analysis.kernels.hmm import baum_welch, baum_welch_numpy

    x = np.asarray(series, dtype=np.float64)[:HMM_MAX_FRAMES]
    f, n = x.shape
    if n == 0:
        return np.zeros(0)
    sd = x.std(axis=0)
    step = quantization_step(x)
    x = (x - x.mean(axis=0)) / np.where(sd > 0, sd, 1.0)
    _sep, amp, sw, up = two_level_split(x, 0.0)
    mu0 = np.stack([-amp * up, amp * (1.0 - up)], axis=1)
    var0 = np.maximum(sw * sw * (f - 2) / f, 1e-3)
    mu0, var0 = np.nan_to_num(mu0), np.nan_to_num(var0, nan=1.0)
    res = baum_welch(x, mu0, var0, HMM_ITERS, 1e-6)
    ll2 = (res if res is not None else baum_welch_numpy(x, mu0, var0, HMM_ITERS, 1e-6))[-1]
    lr = 2.0 * (ll2 + 0.5 * f * (math.log(2.0 * math.pi) + 1.0))
    lr = np.where(sd > 0, np.maximum(lr, 0.0), 0.0)
    # a series on a few codes is two-level by quantization, not by a trap: no test (NaN)
    return np.where(np.nan_to_num(sw) * sd >= HMM_MIN_SW_STEPS * step, lr, np.nan)


def telegraph_test(series: np.ndarray) -> tuple[np.ndarray, str]:
    """(``telegraph_lr`` per column of ``series``, NaN where untested; a note for the result,
    "" if none): compare with ``hmm_null_threshold`` at the p a decision needs."""
    lr = telegraph_lr(series)
    n = int(np.isnan(lr).sum())
    return lr, (f"{n} candidates' series sit on too few codes (within-level noise < {HMM_MIN_SW_STEPS:g} "
                 "quantization steps) for the telegraph ratio: a series on two or three codes is two-level by "
                 "quantization; only the two-level split tested them" if n else "")


#: the within-level noise (the two-means split's, in quantization steps) a series needs for the
#: telegraph ratio: white series rounded to integer codes reach the p = 1e-3 threshold 5-24 % of
#: the time at sigma 0.6 DN (12-256 frames, random offsets), at the nominal rate from ~0.8 DN;
#: a split within-level noise >= 0.6 steps keeps sigma >= 0.7-0.9 steps, where the measured
#: rate is 0.05-0.14 % at p = 1e-3
HMM_MIN_SW_STEPS = 0.6


def quantization_step(series: np.ndarray) -> np.ndarray:
    """Per column of ``series`` (F, n) the smallest nonzero difference between two of its
    values: the code step of integer data (1 DN; 16 for 12-bit data stored MSB-aligned in 16
    bits), ~0 for continuous data; inf for a constant column."""
    x = np.sort(np.asarray(series, dtype=np.float64), axis=0)
    d = np.diff(x, axis=0)
    return np.where(d > 0, d, np.inf).min(axis=0, initial=np.inf)


#: p-values of the null table and its frame counts (``benchmarks/bench_defect_hmm_null.py
#: --table``: 100 000 white standard normal series per frame count, fixed seeds; its measured
#: false-alarm rates on other seeds in ``benchmarks/defect_hmm_null.md``)
HMM_NULL_P = (1e-2, 3e-3, 1e-3)
HMM_NULL_FRAMES = tuple(range(12, 33)) + tuple(range(36, 65, 4)) + tuple(range(72, 129, 8)) + tuple(range(144, 257, 16))
HMM_NULL: dict[int, tuple[float, ...]] = {
    12: (14.874, 17.877, 20.506),
    13: (14.602, 17.290, 19.892),
    14: (14.638, 17.510, 20.014),
    15: (14.523, 17.428, 20.207),
    16: (14.378, 17.362, 19.826),
    17: (14.178, 17.122, 19.963),
    18: (14.106, 17.008, 19.550),
    19: (14.138, 16.935, 19.566),
    20: (14.135, 16.912, 19.362),
    21: (14.031, 16.860, 19.490),
    22: (14.011, 16.807, 19.218),
    23: (13.930, 16.631, 18.830),
    24: (13.866, 16.782, 19.463),
    25: (13.835, 16.537, 18.833),
    26: (13.809, 16.601, 19.078),
    27: (13.809, 16.557, 19.311),
    28: (13.790, 16.379, 18.744),
    29: (13.747, 16.588, 19.180),
    30: (13.637, 16.345, 18.684),
    31: (13.684, 16.549, 18.869),
    32: (13.706, 16.458, 19.207),
    36: (13.681, 16.325, 18.905),
    40: (13.457, 16.067, 18.794),
    44: (13.389, 16.069, 18.364),
    48: (13.323, 15.935, 18.334),
    52: (13.246, 16.063, 18.463),
    56: (13.099, 15.905, 18.062),
    60: (13.005, 15.701, 18.214),
    64: (13.033, 15.753, 18.356),
    72: (12.860, 15.753, 18.303),
    80: (12.891, 15.585, 18.113),
    88: (12.680, 15.366, 17.837),
    96: (12.559, 15.387, 17.997),
    104: (12.399, 15.104, 17.587),
    112: (12.226, 14.948, 17.375),
    120: (12.305, 15.046, 17.721),
    128: (12.212, 14.951, 17.610),
    144: (11.975, 14.758, 17.371),
    160: (11.845, 14.793, 17.344),
    176: (11.726, 14.482, 17.087),
    192: (11.863, 14.750, 17.283),
    208: (11.499, 14.325, 16.849),
    224: (11.457, 14.188, 17.133),
    240: (11.326, 14.144, 16.633),
    256: (11.360, 14.339, 16.670),
}


def hmm_null_threshold(frames: int, p: float) -> float:
    """The ratio a white Gaussian series of ``frames`` frames reaches with probability ``p``
    (one of ``HMM_NULL_P``): the table's value, between two of its frame counts the larger
    of the two (conservative); over HMM_MAX_FRAMES that of HMM_MAX_FRAMES (the statistic
    uses that many frames); inf below the table (no test)."""
    j = HMM_NULL_P.index(p)
    f = min(int(frames), HMM_MAX_FRAMES)
    if f < HMM_NULL_FRAMES[0] or not HMM_NULL:
        return math.inf
    if f in HMM_NULL:
        return HMM_NULL[f][j]
    lo = max(g for g in HMM_NULL_FRAMES if g < f)
    hi = min(g for g in HMM_NULL_FRAMES if g > f)
    return max(HMM_NULL[lo][j], HMM_NULL[hi][j])


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
