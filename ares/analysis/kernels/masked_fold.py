"""One pass over integer frames for ``MaskedStackAccumulator`` (numba, ``ares.analysis.kernels.jit``).

The numpy fold converts each frame to float64, subtracts the shift, zeroes the masked
pixels and reduces it five times (pixel sums, squares, row and column sums): about 1.7 ms
of memory traffic a VGA frame, in the scan's acquiring thread. Here each good pixel is
read once. Integer frames make every sum here an exact integer in float64 (|values| <
2**16, sums far below 2**53), so the order of summation cannot change a bit: the
results equal the numpy fold's exactly (tested). Float frames keep the numpy fold.

A masked stack whose per-pixel sums come from its full-frame stack (``pixels``) only needs
the row and column sums: ``lines`` forms them from every pixel's value, the few masked
pixels' and the shift's sums subtracted, in int64 (no test per pixel; a third of the
pass's time on a 4096x3072 frame).

Per stack, not per frame: ``shift`` writes the stack's shift into a pooled array where
``ares.analysis.kernels.recycle`` holds one, ``line_plan`` keeps the last mask's coordinates (a
run's stacks share one mask), and ``Ride`` lets the full-frame stack call its masked view
without keeping it alive (no reference cycle: both are freed with their StackSet).
"""

from __future__ import annotations

import weakref

import numpy as np

from ares.analysis.kernels import recycle

_kernel_c = None
_loaded = False
_lines_c = None
_lines_loaded = False
_shift_c = None
_shift_loaded = False
_NO_SUMS = np.zeros((1, 1))  # stands for s1/s2 when only the line sums are wanted
_coords: list = []  # [(good, rows, columns)] of the last mask line_plan met


class Ride:
    """``StackAccumulator._on_fold`` for a masked stack riding on it (``MaskedStackAccumulator
    .ride``): its ``_from_pixels``, reached through a weak reference."""

    __slots__ = ("ref",)

    def __init__(self, masked) -> None:
        self.ref = weakref.ref(masked)

    def __call__(self, *args) -> None:
        m = self.ref()
        if m is not None:
            m._from_pixels(*args)


def shift(frame: np.ndarray, mask: np.ndarray, small: bool, off: int = 0) -> np.ndarray:
    """A masked stack's shift: ``frame`` + ``off`` at the good pixels, 0 at the masked ones
    (``mask`` True), float32 for 8/16-bit frames (exact: |values| < 2**17), else float64; no
    temporaries (a uint16 frame of a batch store, x ^ 0x8000, is read as int16 + 2**15)."""
    x0 = recycle.empty(frame.shape, np.float32 if small else np.float64)
    np.copyto(x0, frame)
    if off:
        x0 += off
    np.copyto(x0, 0, where=mask)
    return x0


def masked_coords(good: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, columns) of the pixels ``good`` excludes, int64, read-only; the last mask's are
    kept (np.nonzero of a 4096x3072 mask: ~50 ms a stack, the comparison a tenth of it)."""
    hit = _coords[0] if _coords else None
    if hit is not None and hit[0].shape == good.shape and np.array_equal(hit[0], good):
        return hit[1], hit[2]
    bi, bj = (a.astype(np.int64) for a in np.nonzero(~good))
    bi.flags.writeable = bj.flags.writeable = False
    _coords[:] = [(good.copy(), bi, bj)]
    return bi, bj


def _kernel(x, x0, good, s1, s2, fr, fc, sums):
    """Per-frame row and column sums of the shifted good pixels into ``fr``/``fc``; with
    ``sums`` also the per-pixel sums and sums of squares into ``s1``/``s2`` (without: a
    masked stack that reads those from its full-frame stack; the test is hoisted out of
    the loop by the compiler)."""
    F, R, C = x.shape
    for f in range(F):
        for j in range(C):
            fc[f, j] = 0.0
        for i in range(R):
            rs = 0.0
            for j in range(C):
                if good[i, j]:
                    d = np.float64(x[f, i, j]) - x0[i, j]
                    if sums:
                        s1[i, j] += d
                        s2[i, j] += d * d
                    rs += d
                    fc[f, j] += d
            fr[f, i] = rs


def _lines_kernel(x, x0r, x0c, bi, bj, fr, fc):
    """Per-frame row/column sums of x - x0 over the good pixels, in int64: every pixel's
    sums, less the masked pixels' values (``bi``, ``bj``), less the good pixels' shift
    summed once per stack (``x0r``, ``x0c``). No test per pixel: a plain pass over the frame."""
    F, R, C = x.shape
    for f in range(F):
        for j in range(C):
            fc[f, j] = -x0c[j]
        for i in range(R):
            rs = np.int64(0)
            for j in range(C):
                v = np.int64(x[f, i, j])
                rs += v
                fc[f, j] += v
            fr[f, i] = rs - x0r[i]
        for k in range(bi.shape[0]):
            v = np.int64(x[f, bi[k], bj[k]])
            fr[f, bi[k]] -= v
            fc[f, bj[k]] -= v


def _shift_kernel(x0, good, xr, xc):
    R, C = x0.shape
    for i in range(R):
        rs = np.int64(0)
        for j in range(C):
            if good[i, j]:
                v = np.int64(x0[i, j])
                rs += v
                xc[j] += v
        xr[i] = rs


def line_plan(x0: np.ndarray, good: np.ndarray):
    """What ``lines`` needs for a stack, once: the shift (integer-valued: the first of the
    stack's 8/16-bit frames) summed over the good pixels of each row and column (int64) and
    the masked pixels' coordinates; None without numba (the caller's other folds apply)."""
    global _shift_c, _shift_loaded
    if not _shift_loaded:
        from ares.analysis.kernels import jit

        _shift_c, _shift_loaded = jit.compiled(_shift_kernel), True
    if _shift_c is None:
        return None
    R, C = x0.shape
    xr, xc = np.zeros(R, np.int64), np.zeros(C, np.int64)
    _shift_c(x0, good, xr, xc)
    return (xr, xc) + masked_coords(good)


def lines(x: np.ndarray, plan):
    """(row sums (F, R), column sums (F, C)) of the shifted good pixels of the integer frames
    ``x`` as float64 -- exact integers, so equal to the numpy fold's bit for bit -- or None
    when the kernel does not apply (no plan, numba missing, float frames)."""
    global _lines_c, _lines_loaded
    if plan is None or x.dtype.kind not in "ui" or x.dtype.itemsize > 2:
        return None
    if not _lines_loaded:
        from ares.analysis.kernels import jit

        _lines_c, _lines_loaded = jit.compiled(_lines_kernel), True
    if _lines_c is None:
        return None
    F, R, C = x.shape
    fr, fc = np.empty((F, R), np.int64), np.empty((F, C), np.int64)
    _lines_c(np.ascontiguousarray(x), *plan, fr, fc)
    return fr.astype(np.float64), fc.astype(np.float64)


def fold(x: np.ndarray, x0: np.ndarray, good: np.ndarray, s1: np.ndarray | None, s2: np.ndarray | None):
    """Add the frames ``x`` (F, R, C integers) shifted by ``x0`` into ``s1``/``s2`` at the
    good pixels (both None: only the line sums); returns (per-frame row sums (F, R),
    column sums (F, C)) of the shifted good pixels, or None when the kernel does not
    apply (numba missing, float frames)."""
    global _kernel_c, _loaded
    if not _loaded:
        from ares.analysis.kernels import jit

        _kernel_c, _loaded = jit.compiled(_kernel), True
    if _kernel_c is None or x.dtype.kind not in "ui" or x.dtype.itemsize > 2:
        return None
    F, R, C = x.shape
    fr, fc = np.empty((F, R)), np.empty((F, C))
    sums = s1 is not None
    if not sums:
        s1 = s2 = _NO_SUMS
    _kernel_c(np.ascontiguousarray(x), x0, good, s1, s2, fr, fc, sums)
    return fr, fc


def warm(dtype=np.uint16) -> None:
    """Load (or compile) the kernel for ``dtype`` frames now (the runner, before a scan)."""
    z = np.zeros((2, 2))
    x, x0, good = np.zeros((1, 2, 2), dtype), z.astype(np.float32), np.ones((2, 2), bool)
    fold(x, x0, good, z, z.copy())
    fold(x, x0, good, None, None)
    lines(x, line_plan(x0, good))
