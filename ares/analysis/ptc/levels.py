"""Per-level statistics for photon transfer: mean and temporal variance of one level.

Pure numpy. A *level* is a set of frames taken at one illumination/exposure setting:
a pair (EMVA 1288) or a longer stack.

- Pair, EMVA 1288 Release 4.0: ``s2 = mean((A-B)^2)/2 - (mu_A-mu_B)^2/2`` -- the second
  term removes a frame-to-frame offset change. Release 3.0 (and its reference data
  set's published numbers) omits it: ``offset_correction=False``.
- Stack: per-pixel temporal variance (ddof=1) averaged over pixels ("pixel-temporal
  mean square"); frame-global offsets are removed first when ``offset_correction``.

Accumulation is exact: int64 for integer data, float64 on data shifted by its mean.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


@dataclass(frozen=True)
class LevelStats:
    mean: float  # DN, over all pixels and frames
    var: float  # temporal variance, DN^2
    n_pixels: int
    n_frames: int
    frac_at_max: float = 0.0  # fraction of samples at the maximum code (0 if max_code unknown)
    frac_at_min: float = 0.0  # fraction of samples at code 0 (clipped black)
    spatial_var: float = float("nan")  # spatial variance of the frame average, temporal/F removed
    line_var2: float = 0.0  # extra sampling variance of ``var`` from row/column-correlated noise, DN^4

    @property
    def dof(self) -> float:
        """Degrees of freedom behind ``var`` (pair: one per pixel)."""
        return float(self.n_pixels * max(self.n_frames - 1, 1))

    @property
    def var_se(self) -> float:
        """Standard error of ``var`` for Gaussian data: ``sqrt(2/dof) * var``, plus the
        sampling of its row- and column-correlated parts when known (``line_var2``): those
        are drawn once per row or column, not once per pixel."""
        return math.sqrt(2.0 / self.dof * (self.var * self.var) + self.line_var2)  # (x * x: inf past float range, where ** raises)


def _clip_fractions(frames: np.ndarray, max_code: int | None) -> tuple[float, float]:
    """(fraction >= max_code, fraction == 0); counted only when the extremes reach them
    (two fast reductions instead of two comparisons of the whole stack, usually)."""
    n = frames.size
    at_min = at_max = 0.0
    if frames.dtype.kind in "ui" and n and frames.min() == 0:
        at_min = float(np.count_nonzero(frames == 0)) / n
    if max_code is not None and n and frames.max() >= max_code:
        at_max = float(np.count_nonzero(frames >= max_code)) / n
    return at_max, at_min


@dataclass(frozen=True)
class PairMoments:
    """One visit of a two-image level: exact sums, clip fractions and the pair's sum image,
    from which both releases' statistics follow (``stats``)."""

    sa: float
    sb: float
    sdd: float  # sum of (a - b)^2, exact for integer data
    n: int
    fmax: float
    fmin: float
    total: np.ndarray  # a + b: exact integers (int32 for 8/16-bit data, int64 above) or float64
    row_diff: np.ndarray  # mean of each row of a minus that of b, float64
    col_diff: np.ndarray  # the same for the columns

    @property
    def avg(self) -> np.ndarray:
        """The averaged image (a + b) / 2, float64."""
        return self.total * 0.5

    def stats(self, offset_correction: bool = True) -> LevelStats:
        mu_a, mu_b = self.sa / self.n, self.sb / self.n
        var = self.sdd / self.n / 2.0
        if offset_correction:
            var -= (mu_a - mu_b) ** 2 / 2.0
        spatial = self.avg_var - var / 2.0
        return LevelStats((self.sa + self.sb) / (2.0 * self.n), var, self.n, 2, self.fmax, self.fmin, spatial)

    @functools.cached_property
    def avg_var(self) -> float:  # both releases' stats read it
        t = self.total
        n = t.size
        if t.dtype.kind == "i" and n > 1 and float(max(int(t.max()), -int(t.min()))) ** 2 * n < 2.0**53:
            tf = t.astype(np.float64).ravel()  # every partial sum below is an integer below 2**53: exact
            s1, s2 = self.sa + self.sb, int(np.dot(tf, tf))  # (the sum of a + b is known)
            return (n * s2 - s1 * s1) / (n * (n - 1)) / 4.0  # exact integers, one rounding
        return float(np.var(t, ddof=1)) / 4.0


def _sum_type(dtype: np.dtype):
    """The type ``a + b`` is exact in: int32 for 8/16-bit integers, int64 for wider ones."""
    if dtype.kind in "uib":
        return np.int32 if dtype.itemsize <= 2 else np.int64
    return np.float64


def pair_moments(a: np.ndarray, b: np.ndarray, max_code: int | None = None) -> PairMoments:
    a = np.asarray(a)
    b = np.asarray(b)
    if a.shape != b.shape:
        raise ValueError(f"pair frames differ in shape: {a.shape} vs {b.shape}")
    from ares.analysis.kernels.pair import pair_pass

    one = pair_pass(a, b, max_code)  # numba: one read of each pixel, the same numbers
    if one is not None:
        (sa, sb, sdd, ma, mb, za, zb), total, rd, cd = one
        n = a.size
        fmax = (ma / n + mb / n) / 2 if max_code is not None else 0.0
        M, N = a.shape
        return PairMoments(int(sa), int(sb), int(sdd), n, fmax, (za / n + zb / n) / 2, total, rd / N, cd / M)
    d = np.subtract(a, b, dtype=np.float64)  # exact for integers: |a - b| < 2**33
    # row and column sums of a - b: exact integers in float64 (below 2**53) for integer data
    dr, dc = d.sum(axis=1), d.sum(axis=0)
    if a.dtype.kind in "ui":
        sa = int(a.sum(dtype=np.int64))  # no int64 copy of the image
        sb = sa - int(dr.sum())
        info = np.iinfo(np.result_type(a, b)) if b.dtype.kind in "ui" else np.iinfo(a.dtype)
        if float(info.max - info.min) ** 2 * d.size < 2.0**53:  # every partial sum of squares is an
            sdd = int(np.dot(d.ravel(), d.ravel()))  # integer below 2**53: exact (16-bit up to ~2 Mpixel)
        else:  # int64: exact while the sum stays below 2**63 (24-bit codes up to ~30 Mpixel)
            di = d.astype(np.int64)
            sdd = int(np.dot(di.ravel(), di.ravel()))
    else:
        sa, sb = float(a.sum(dtype=np.float64)), float(b.sum(dtype=np.float64))
        sdd = float(np.dot(d.ravel(), d.ravel()))
    dr /= a.shape[1]
    dc /= a.shape[0]
    del d
    fa, fb = _clip_fractions(a, max_code), _clip_fractions(b, max_code)
    total = np.add(a, b, dtype=_sum_type(a.dtype if a.dtype == b.dtype else np.result_type(a, b)))
    return PairMoments(sa, sb, sdd, a.size, (fa[0] + fb[0]) / 2, (fa[1] + fb[1]) / 2, total, dr, dc)


def pair_step(a: np.ndarray, b: np.ndarray, max_code: int | None):
    """Everything every EMVA 1288 release reads from one two-image step, in one visit of
    the images: (Release 3.0 ``LevelStats``, Release 4.0 ``LevelStats`` (Eq. 18), the
    averaged image's spatial variances (``emva_spatial.Split``: Eq. 32 with the 4.0
    high-pass; unfiltered when the image is smaller than the filter), mu[0] - mu[1])."""
    from ares.analysis.spatial.nonuniformity import split
    from ares.analysis.spatial.pattern_se import temporal_parts

    pm = pair_moments(a, b, max_code)
    del a, b  # (the caller may hold no other reference: the high-pass below needs neither)
    s3, s4 = pm.stats(False), pm.stats(True)
    M, N = pm.total.shape
    # temporal variance of the row / column means with the frame-global offset removed
    rv = float(np.var(pm.row_diff)) / 2
    cv = float(np.var(pm.col_diff)) / 2
    try:
        sp = split(pm.total, s4.var, 2, "4.0", rv, cv, scale=0.5, mean=s4.mean)
    except ValueError:
        sp = split(pm.total, s4.var, 2, "none", rv, cv, scale=0.5, mean=s4.mean)
    _, R, C = temporal_parts(s4.var, M, N, rv, cv)  # row/column-correlated temporal parts
    s4 = dataclasses.replace(s4, line_var2=2 * max(R, 0.0) ** 2 / M + 2 * max(C, 0.0) ** 2 / N)
    return s3, s4, sp, (pm.sa - pm.sb) / pm.n


def pair_stats(a: np.ndarray, b: np.ndarray, max_code: int | None = None,
               offset_correction: bool = True) -> LevelStats:
    """Mean and temporal variance of a flat (or dark) pair."""
    return pair_moments(a, b, max_code).stats(offset_correction)


def stack_stats(stack: np.ndarray, max_code: int | None = None,
                offset_correction: bool = True) -> LevelStats:
    """Mean and pixel-temporal mean-square variance of a (frames, rows, cols) stack."""
    s = np.asarray(stack)
    if s.ndim != 3 or s.shape[0] < 2:
        raise ValueError("a stack needs shape (frames>=2, rows, cols)")
    f = s.shape[0]
    x = s.astype(np.float64)
    m = x.mean()
    x -= m
    if offset_correction:
        x -= x.mean(axis=(1, 2), keepdims=True)
    var = float(np.mean(np.var(x, axis=0, ddof=1)))
    spatial = float(np.var(x.mean(axis=0), ddof=1)) - var / f
    fmax, fmin = _clip_fractions(s, max_code)
    return LevelStats(float(m), var, s.shape[1] * s.shape[2], f, fmax, fmin, spatial)


def level_stats(frames: np.ndarray, max_code: int | None = None,
                offset_correction: bool = True) -> LevelStats:
    """Pair formula for two frames, stack formula otherwise."""
    frames = np.asarray(frames)
    if frames.ndim == 3 and frames.shape[0] == 2:
        return pair_stats(frames[0], frames[1], max_code, offset_correction)
    return stack_stats(frames, max_code, offset_correction)


@dataclass(frozen=True)
class SpatialStats:
    """Spatial statistics of a stack's averaged image (EMVA 1288 non-uniformity)."""

    mean: float
    s2_measured: float  # spatial variance of the averaged image (ddof=1)
    s2_temporal: float  # mean per-pixel temporal variance (ddof=1)
    n_frames: int
    n_pixels: int

    @property
    def s2_spatial(self) -> float:
        """Spatial variance with the residual temporal part ``s2_temporal/L`` removed."""
        return self.s2_measured - self.s2_temporal / self.n_frames


def spatial_stats(frames) -> SpatialStats:
    """Spatial statistics of a stack, given as a (frames, rows, cols) array or any iterable
    of 2-D frames (streamed: memory of a few frames, whatever the stack length)."""
    return stack_moments(frames)[0]


@dataclass(frozen=True)
class LineTemporal:
    """Temporal variances of a stack with the frame-global offset removed: per pixel, and of
    the row means and column means (their frame-to-frame variance, averaged over rows or
    columns). They separate row- and column-correlated temporal noise from white noise."""

    pixel: float
    rows: float
    cols: float


def _square_type(dtype: np.dtype):
    """The narrowest type that holds the square of every value of an integer ``dtype``."""
    if dtype.itemsize <= 2:  # (bool: one byte, unsigned)
        return {(1, False): np.uint16, (2, False): np.uint32, (1, True): np.int16, (2, True): np.int32}[
            (dtype.itemsize, dtype.kind == "i")]
    return np.int64  # (32-bit: the sum of squares is exact in int64 while it fits, as before)


class _Carried:
    """A per-pixel sum held as int64 total + uint16 wrap count x 2**32 + uint32 part; row
    blocks of it come out as int64 (``[r0:r1]``), the whole image never needs to."""

    def __init__(self, total, carry, part):
        self.total, self.carry, self.part = total, carry, part

    def __getitem__(self, rows: slice) -> np.ndarray:
        out = self.part[rows].astype(np.int64)
        if self.carry is not None:
            out += self.carry[rows].astype(np.int64) << 32
        if self.total is not None:
            out += self.total[rows]
        return out

    def whole(self) -> np.ndarray:
        return self[0:self.part.shape[0]]


class _NarrowSums:
    """Per-pixel sums of unsigned 8/16-bit frames and of their squares kept in uint32 (numpy
    adds them 2-3x faster than into int64: half the memory traffic), exact whatever the
    stack length: when a sum could pass 2**32 (the squares of 12-bit data after 256 frames),
    its wraps are counted per pixel in uint16 (a frame's value or square is below 2**32, so
    it wraps at most once: where the new sum is below what was added), and every 65535
    frames the count goes into an int64 total. A 500-frame 12-bit stack holds 2 + 4 + 4
    bytes a pixel, not 8 + 8 (memory of a stack's accumulation near independent of L)."""

    LIMIT = 2**32 - 1

    def __init__(self, shape: tuple[int, int]):
        self.parts = [np.zeros(shape, np.uint32), np.zeros(shape, np.uint32)]  # sum x, sum x^2
        self.carries: list[np.ndarray | None] = [None, None]
        self.counted = [0, 0]  # frames added since the wrap count was last emptied
        self.totals_: list[np.ndarray | None] = [None, None]
        self.room = [self.LIMIT, self.LIMIT]
        self._sq = np.empty(shape, np.uint32)  # the frame's squares and wraps, in buffers kept for
        self._wrapped = np.empty(shape, np.bool_)  # the stack (no allocation a frame: the heap stays put)

    def add(self, f: np.ndarray) -> None:
        hi = int(f.max())
        sq = np.square(f, out=self._sq, dtype=np.uint32)
        for k, x, need in ((0, f, hi), (1, sq, hi * hi)):
            part = self.parts[k]
            if self.carries[k] is None and need > self.room[k]:
                self.carries[k] = np.zeros(part.shape, np.uint16)
            np.add(part, x, out=part)
            if self.carries[k] is None:
                self.room[k] -= need
                continue
            np.add(self.carries[k], np.less(part, x, out=self._wrapped), out=self.carries[k], casting="unsafe")
            self.counted[k] += 1
            if self.counted[k] == 65535:
                self._fold(k)

    def _fold(self, k: int) -> None:
        """Move part and wrap count into the int64 total."""
        if self.totals_[k] is None:
            self.totals_[k] = np.zeros(self.parts[k].shape, np.int64)
        self.totals_[k] += _Carried(None, self.carries[k], self.parts[k]).whole()
        self.parts[k].fill(0)
        if self.carries[k] is not None:
            self.carries[k].fill(0)
        self.counted[k] = 0

    def totals(self) -> tuple[np.ndarray, "np.ndarray | _Carried"]:
        """(sum x, sum x^2): the uint32 sum if it never wrapped; else sum x as int64, and
        sum x^2 as a ``_Carried`` (row blocks of int64 on demand)."""
        self._sq = self._wrapped = None
        out = [p if c is None and t is None else _Carried(t, c, p)
               for p, c, t in zip(self.parts, self.carries, self.totals_)]
        if isinstance(out[0], _Carried):
            out[0] = out[0].whole()
        return out[0], out[1]

    def widen(self) -> tuple[np.ndarray, np.ndarray]:
        """Both sums as int64 totals, for adding wider frames from here on."""
        for k in (0, 1):
            self._fold(k)
        return self.totals_[0], self.totals_[1]


class StackMoments(NamedTuple):
    stats: SpatialStats
    mean_image: np.ndarray  # <y>, Eq. 33 of EMVA 1288 4.0, float64
    line: LineTemporal
    total: np.ndarray | None  # the exact per-pixel sum of integer frames (uint32 or int64), else None


def stack_moments(frames) -> StackMoments:
    """The statistics, averaged image, line temporal variances and (integer frames) the
    exact sum image of a stack, in one streamed pass. Integer data are summed exactly
    (per-pixel sums of x and x^2); floats are summed in float64 after subtracting the first
    frame's mean (no cancellation)."""
    s1 = s2 = shift = narrow = shape = None
    n = 0
    fm, r1, r2, c1, c2 = [], 0.0, 0.0, 0.0, 0.0
    for f in frames:
        f = np.asarray(f)
        if f.ndim != 2:
            raise ValueError("a stack needs shape (frames>=2, rows, cols)")
        if shape is None:
            shape = f.shape
            exact = f.dtype.kind in "ub" or (f.dtype.kind == "i" and f.dtype.itemsize <= 4)
            acc = np.int64 if exact else np.float64
            shift = 0 if exact else float(f.mean())
            if f.dtype.kind in "ub" and f.dtype.itemsize <= 2:
                narrow = _NarrowSums(shape)
            else:
                s1, s2 = np.zeros(shape, acc), np.zeros(shape, acc)
        elif f.shape != shape:
            raise ValueError(f"frame {n} has shape {f.shape}, the first {shape}")
        if narrow is not None and not (f.dtype.kind in "ub" and f.dtype.itemsize <= 2):  # (a wider frame
            (s1, s2), narrow = narrow.widen(), None  # in a stack that began narrow: int64 from here on)
        if narrow is not None:
            x = f
            narrow.add(x)
            # exact uint32 row and column sums (rows and columns of < 65537 pixels); the same
            # float64 means as numpy's mean of the frame
            rm = x.sum(axis=1, dtype=np.uint32) / x.shape[1]
            cm = x.sum(axis=0, dtype=np.uint32) / x.shape[0]
        else:
            if shift:
                x = f.astype(s1.dtype) - shift
                s1 += x
                s2 += x * x
            else:  # integers: summed as they are (cast in numpy's small buffers), squared in the narrowest
                x = f  # type that holds them -- no int64 copy of the frame
                np.add(s1, x, out=s1, casting="unsafe")
                np.add(s2, np.square(x, dtype=_square_type(x.dtype)), out=s2, casting="unsafe")
            rm = x.mean(axis=1, dtype=np.float64)
            cm = x.mean(axis=0, dtype=np.float64)
        g = float(rm.mean())
        cm -= g
        rm -= g
        fm.append(g)
        r1, r2, c1, c2 = r1 + rm, r2 + rm * rm, c1 + cm, c2 + cm * cm
        n += 1
    if n < 2:
        raise ValueError("a stack needs shape (frames>=2, rows, cols)")
    if narrow is not None:
        s1, s2 = narrow.totals()
        narrow = None
    avg = s1 / n  # per-pixel mean (minus the shift)
    mean_avg = float(avg.mean())
    # the mean per-pixel temporal variance, sum (s2 - s1 * avg) / (n - 1), and the spatial
    # variance of avg, a block of rows at a time: no image-sized temporaries beside avg
    rows = max(1, (1 << 16) // max(avg.shape[1], 1))
    sum_t = sum_s = 0.0
    for r in range(0, avg.shape[0], rows):
        v = s1[r:r + rows] * avg[r:r + rows]
        np.subtract(s2[r:r + rows], v, out=v)
        sum_t += float(v.sum())
        np.subtract(avg[r:r + rows], mean_avg, out=v)
        sum_s += float(np.dot(v.ravel(), v.ravel()))
    st = SpatialStats(mean_avg + (shift or 0.0), sum_s / (avg.size - 1), sum_t / (n - 1) / avg.size, n, avg.size)
    line = LineTemporal(st.s2_temporal - float(np.var(fm, ddof=1)),
                        float(np.mean((r2 - r1 * r1 / n) / (n - 1))), float(np.mean((c2 - c1 * c1 / n) / (n - 1))))
    if shift:
        avg += shift
    return StackMoments(st, avg, line, None if shift or s1.dtype.kind == "f" else s1)
