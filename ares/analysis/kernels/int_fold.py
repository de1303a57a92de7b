"""One pass over a block of 8/16-bit frames for ``StackAccumulator`` (numba, ``ares.analysis.kernels.jit``).

The numpy kernel (``ares.analysis.kernels.small_int_fold``) keeps every partial sum exact in
float32 and rebuilds the squares from two float32 parts: seven passes over the block and
its scratch, and float32 totals moved to int64 when the stack ends. Here each pixel of
the block is read once and added in int64 straight into the accumulator's sums: the pixel
sums, the sums of squares, the per-frame row and column sums, and the clip counts (values
at the top code and at 0: ``StackSet``'s, without a second pass). Every value is an integer
below 2**16 and every sum an int64 far from overflow (2**32 per square, 2**31 frames), so
the order of summation cannot change a bit: the results equal the numpy kernel's exactly
(tested). On a 4096x3072 stream this is what lets the live pipeline keep up with 30
frames/s (``benchmarks/live_pipeline.md``).

A large block is split into bands of rows folded at once on ``threads()`` cores (the kernel
releases the GIL): each band writes its own rows of the sums and row sums, and its own
column sums and clip counts, added up after (integers: the same bits as one pass).
"""

from __future__ import annotations

import os
import threading

import numpy as np

_kernel_c = None
_loaded = False
_extremes_c = None
_extremes_loaded = False


def _kernel(x, off, s1, s2, fr, fc, top, cnt, r0, r1):
    """Add the rows ``r0:r1`` of the frames ``x`` (B, R, C small integers) plus ``off`` into
    ``s1``/``s2`` (R, C int64); ``fr`` (B, R) and ``fc`` (B, C) int64 get the per-frame row
    sums (of those rows) and column sums (over those rows); ``cnt`` (2,) int64 gets the count
    of values at or above ``top`` and of values 0 (the clip counts, in the same read of each
    pixel)."""
    B, R, C = x.shape
    for f in range(B):
        for j in range(C):
            fc[f, j] = 0
    n_top = np.int64(0)
    n_zero = np.int64(0)
    for i in range(r0, r1):
        for f in range(B):
            rs = np.int64(0)
            for j in range(C):
                v = np.int64(x[f, i, j]) + off
                u = np.uint32(v)  # |v| < 2**16: v*v < 2**32 is exact modulo 2**32 (a vector multiply)
                s1[i, j] += v
                s2[i, j] += np.int64(np.uint32(u * u))
                rs += v
                fc[f, j] += v
                n_top += v >= top
                n_zero += v == 0
            fr[f, i] = rs
    cnt[0] += n_top
    cnt[1] += n_zero


def _extremes_kernel(d, top):
    """(values >= top, values == 0) of a frame (any strides: a region or a Bayer plane)."""
    n_top = 0
    n_zero = 0
    R, C = d.shape
    for i in range(R):
        for j in range(C):
            v = d[i, j]
            n_top += v >= top
            n_zero += v == 0
    return n_top, n_zero


def extremes(d: np.ndarray, top: int) -> tuple[int, int]:
    """How many values of the 2-D frame ``d`` are at or above ``top`` (clipped high) and how
    many are 0 (clipped low): one pass where the kernel is available, else numpy's two."""
    global _extremes_c, _extremes_loaded
    from ares.analysis.kernels import jit

    if not jit.avoiding() and d.ndim == 2 and d.dtype.kind in "ui":
        if not _extremes_loaded:
            _extremes_c, _extremes_loaded = jit.compiled(_extremes_kernel), True
        if _extremes_c is not None:
            a, b = _extremes_c(d, d.dtype.type(min(top, np.iinfo(d.dtype).max)))
            return int(a) if top <= np.iinfo(d.dtype).max else 0, int(b)
    return int(np.count_nonzero(d >= top)), int(np.count_nonzero(d == 0))


NO_TOP = 1 << 62  # a ``top`` no value reaches: clip counts not wanted
SPLIT_VALUES = 1 << 22  # blocks of at least this many values are split over threads() cores
_pool = None
_pool_lock = threading.Lock()


def threads() -> int:
    """Cores a large block is folded on: ``ARES_FOLD_THREADS`` if set, else the cores this
    process may run on, at most 2 (the fold is bound by the memory bus beyond)."""
    env = os.environ.get("ARES_FOLD_THREADS", "")
    if env.strip().isdigit() and int(env) >= 1:
        return int(env)
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    return max(1, min(2, n))


def _executor(workers: int):
    global _pool
    with _pool_lock:
        if _pool is None or _pool._max_workers < workers:
            from concurrent.futures import ThreadPoolExecutor

            _pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="ares-fold")
        return _pool


def _split(x, off, s1, s2, fr, fc, top, cnt, parts: int) -> None:
    """The kernel over ``parts`` bands of rows at once (this thread folds the last)."""
    B, R, C = x.shape
    edges = [R * k // parts for k in range(parts + 1)]
    fcs, cnts = np.empty((parts, B, C), np.int64), np.zeros((parts, 2), np.int64)
    pool = _executor(parts - 1)
    jobs = [pool.submit(_kernel_c, x, off, s1, s2, fr, fcs[k], top, cnts[k], edges[k], edges[k + 1])
            for k in range(parts - 1)]
    _kernel_c(x, off, s1, s2, fr, fcs[-1], top, cnts[-1], edges[-2], edges[-1])
    for j in jobs:
        j.result()
    np.sum(fcs, axis=0, out=fc)
    cnt += cnts.sum(axis=0)


def fold(x, off: int, s1: np.ndarray, s2: np.ndarray, top: int = NO_TOP, cnt: np.ndarray | None = None,
         parts: int | None = None):
    """Fold the block ``x`` (a (B, R, C) array or a list of (R, C) arrays of one 8/16-bit
    integer type; each value stands for value + ``off``) into the int64 sums ``s1``/``s2``;
    returns the per-frame (row sums (B, R), column sums (B, C)) as int64, or None when the
    kernel is not available (numba missing or ``ARES_NO_NUMBA``): the caller's numpy path.
    ``cnt`` ((2,) int64): the values (+ ``off``) at or above ``top`` and those equal to 0
    are added to it, as ``extremes`` counts them (the fold reads each pixel once for both).
    ``parts``: bands of rows folded at once (default: ``threads()`` for a block of at least
    SPLIT_VALUES values, else 1; the same sums either way)."""
    global _kernel_c, _loaded
    from ares.analysis.kernels import jit

    if jit.avoiding():  # (ares emva: not worth loading numba for)
        return None
    if not _loaded:
        _kernel_c, _loaded = jit.compiled(_kernel), True
    if _kernel_c is None:
        return None
    if isinstance(x, list):
        x = np.stack(x)
    B, R, C = x.shape
    fr, fc = np.empty((B, R), np.int64), np.empty((B, C), np.int64)
    if cnt is None:
        cnt = np.zeros(2, np.int64)
    if parts is None:
        parts = threads() if x.size >= SPLIT_VALUES else 1
    parts = max(1, min(int(parts), R))
    args = (np.ascontiguousarray(x), np.int64(off), s1, s2, fr, fc, np.int64(min(top, NO_TOP)), cnt)
    if parts == 1:
        _kernel_c(*args, 0, R)
    else:
        _split(*args, parts)
    return fr, fc


def warm() -> None:
    """Load (or compile) the kernel for every frame type it meets now (the runner, before a scan)."""
    for dtype in (np.uint8, np.int8, np.uint16, np.int16):
        s = np.zeros((2, 2), np.int64)
        fold(np.zeros((1, 2, 2), dtype), 0, s, s.copy())
        z = np.zeros((4, 4), dtype)
        extremes(z, 1)  # a whole frame
        extremes(z[::2, ::2], 1)  # a Bayer plane (strided)
