"""One pass over a two-image level for ``levels.pair_moments`` (numba, ``ares.analysis.kernels.jit``).

The numpy path forms the difference and the sum of the images and reduces them and the
images several times (``levels.pair_step``). Here each pixel of both images is read
once. Every sum is an exact integer (int64), and the sum image is ``a + b`` (int32) as in
the numpy path, so the results are bit-identical (tested).
``ares emva`` takes the numpy path (``ares.analysis.kernels.jit.avoided``: not worth loading numba for).
"""

from __future__ import annotations

import numpy as np

_kernel_c = None
_loaded = False


def _kernel(a, b, max_code, total, rows_d, cols_d, counts):
    """counts: [sum a, sum b, sum (a-b)^2, a >= max_code, b >= max_code, a == 0, b == 0];
    total = a + b; rows_d, cols_d: the row and column sums of a - b."""
    M, N = a.shape
    sa = sb = sdd = ma = mb = za = zb = 0
    for j in range(N):
        cols_d[j] = 0
    for i in range(M):
        ra = rb = 0
        for j in range(N):
            x = np.int64(a[i, j])
            y = np.int64(b[i, j])
            ra += x
            rb += y
            d = x - y
            cols_d[j] += d
            sdd += d * d
            total[i, j] = x + y
            if max_code >= 0:
                ma += x >= max_code
                mb += y >= max_code
            za += x == 0
            zb += y == 0
        rows_d[i] = ra - rb
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
    """(counts (7 int64, see ``_kernel``), a + b (int32), row and column sums of a - b
    (float64: exact integers)), or None when the kernel does not apply (numba missing; not
    8/16-bit integer images of one dtype)."""
    global _kernel_c, _loaded
    from ares.analysis.kernels import jit

    if jit.avoiding():  # (ares emva: not worth loading numba for)
        return None
    if not _loaded:
        _kernel_c, _loaded = jit.compiled(_kernel), True
    if _kernel_c is None or a.dtype != b.dtype or a.dtype.kind not in "ui" or a.dtype.itemsize > 2 or a.ndim != 2:
        return None
    M, N = a.shape
    total = np.empty((M, N), np.int32)
    rd, cd, counts = np.empty(M, np.int64), np.empty(N, np.int64), np.empty(7, np.int64)
    _kernel_c(np.ascontiguousarray(a), np.ascontiguousarray(b), -1 if max_code is None else int(max_code), total,
              rd, cd, counts)
    return counts, total, rd.astype(np.float64), cd.astype(np.float64)
