"""One pass over a two-image level for ``levels.pair_moments`` (numba, ``ares.jit``).

The numpy path converts both images to int64, forms their difference, reduces it and
the images several times and the row/column means twice more (``emva4_sheet.pair_step``):
~8 ms a VGA pair, a hundred pairs in the reference data set. Here each pixel of both
images is read once. Every sum is an exact integer (int64), and the averaged image is
``float64(a + b) * 0.5`` as in the numpy path, so the results are bit-identical (tested).
``ares emva`` takes the numpy path (``ares.jit.avoided``: not worth loading numba for).
"""

from __future__ import annotations

import numpy as np

_kernel_c = None
_loaded = False


def _kernel(a, b, max_code, avg, rows_a, rows_b, cols_a, cols_b, counts):
    """counts: [sum a, sum b, sum (a-b)^2, a >= max_code, b >= max_code, a == 0, b == 0]."""
    M, N = a.shape
    sa = sb = sdd = ma = mb = za = zb = 0
    for j in range(N):
        cols_a[j] = 0
        cols_b[j] = 0
    for i in range(M):
        ra = rb = 0
        for j in range(N):
            x = np.int64(a[i, j])
            y = np.int64(b[i, j])
            ra += x
            rb += y
            cols_a[j] += x
            cols_b[j] += y
            d = x - y
            sdd += d * d
            avg[i, j] = np.float64(x + y) * 0.5
            if max_code >= 0:
                ma += x >= max_code
                mb += y >= max_code
            za += x == 0
            zb += y == 0
        rows_a[i] = ra
        rows_b[i] = rb
        sa += ra
        sb += rb
    counts[0] = sa
    counts[1] = sb
    counts[2] = sdd
    counts[3] = ma
    counts[4] = mb
    counts[5] = za
    counts[6] = zb


def pair_pass(a: np.ndarray, b: np.ndarray, max_code: int | None):
    """(counts (7 int64, see ``_kernel``), averaged image float64, row sums of a and b,
    column sums of a and b (int64)), or None when the kernel does not apply (numba
    missing; not 8/16-bit integer images of one dtype)."""
    global _kernel_c, _loaded
    from ares import jit

    if jit.avoiding():  # (ares emva: not worth loading numba for)
        return None
    if not _loaded:
        _kernel_c, _loaded = jit.compiled(_kernel), True
    if _kernel_c is None or a.dtype != b.dtype or a.dtype.kind not in "ui" or a.dtype.itemsize > 2 or a.ndim != 2:
        return None
    M, N = a.shape
    avg = np.empty((M, N))
    ra, rb, ca, cb, counts = (np.empty(M, np.int64), np.empty(M, np.int64), np.empty(N, np.int64),
                              np.empty(N, np.int64), np.empty(7, np.int64))
    _kernel_c(np.ascontiguousarray(a), np.ascontiguousarray(b), -1 if max_code is None else int(max_code), avg,
              ra, rb, ca, cb, counts)
    return counts, avg, ra, rb, ca, cb
