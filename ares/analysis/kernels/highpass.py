"""The EMVA 1288 high-pass of an integer image in one streaming pass (numba, ``ares.analysis.kernels.jit``),
for ``emva_spatial.split`` and ``emva_spatial.highpass``.

The numpy path (``emva_spatial._highpass_scaled``) forms W x - S over whole blocks of rows
with a dozen array passes (the exact integer box sums of ``_box_sums``) and a float64 image
of each block. Here each row of the image is read once: it is box-summed along the row
(running sums: two additions a pixel whatever the width), the rows are box-summed down the
columns with running sums over a ring of the last rows (the passes of Linear 4.0 Section
8.1: box 7, box 11, the 3-tap binomial; 3.1 Eq. 84: box 5), and each filtered row's
``z = W x - S`` (W the filter's total weight) is reduced at once to what ``split`` reads:
its row sums and column sums (int64, exact) and the sum of (z - cz)^2 (float64, cz an
integer near the first row's mean) -- or written out times a scale for ``highpass``.

Exactness: the sums are those of the numpy path, in the same integer type (int32 when
W times the largest distance from the image's centre fits it, else int64; the caller
checks the int64 bound), so every z is the same integer. The float64 sum of squares is
added in another order than numpy's ``dot`` (four interleaved partial sums a row, rows in
order): the split's variances agree with the numpy path's to ~1e-13 relative (tested).
"""

from __future__ import annotations

import numpy as np

_kernel_c = None
_loaded = False


def _row_box(src, n, w, dst):
    """dst[j] = src[j] + ... + src[j + w - 1] for j < n - w + 1 (a running sum: two
    additions a sample whatever w; binary doubling, as ``emva_spatial._box_sums``, was 2x
    slower here: numba does not vectorize its loops over a variable buffer)."""
    s = src[0] - src[0]
    for k in range(w):
        s += src[k]
    dst[0] = s
    for j in range(1, n - w + 1):
        s += src[j + w - 1] - src[j - 1]
        dst[j] = s


def _kernel(x, c, W, w1, w2, binom, a, t1, t2, H, V1, V2, acc1, acc2, zr, rowsum, colsum, zout, f, res):
    """High-pass ``x - c`` (2-D integers) by box ``w1``, box ``w2`` (0: none) and the
    binomial (``binom``) along both axes, the valid part only. ``a``, ``t1``, ``t2``: row
    buffers (the centred row and the row after each box), ``H`` (w1 + 1 rows), ``V1`` (w2
    + 1 rows), ``V2`` (3 rows): rings of rows after the horizontal pass and each vertical
    box; ``acc1``, ``acc2``: the running column sums -- all of the work type; ``zr``: a
    filtered row (int32 when 2 W times the largest distance from ``c`` fits it, else
    int64: every z and z - cz is then exact in float64, below 2**53). Out:
    ``rowsum``, ``colsum`` (int64) of z = W (x - c) - S; ``res`` = [sum (z - cz)^2, cz];
    ``zout`` (unless it has no rows): z * f."""
    M0, N0 = x.shape
    bb = (w1 - 1) + (w2 - 1 if w2 > 0 else 0) + (2 if binom else 0)
    b = bb // 2
    N = N0 - bb
    n1 = N0 - w1 + 1
    n2 = n1 - w2 + 1 if w2 > 0 else n1
    write = zout.shape[0] > 0
    for j in range(N):
        colsum[j] = 0
    sq = 0.0
    cz = 0
    fcz = 0.0
    Wt = acc1[0] - acc1[0] + W  # W in the work type (W (x - c) fits it)
    for r in range(M0):
        # along the row: box w1, box w2, binomial -> H[r % (w1 + 1)]
        for j in range(N0):
            a[j] = x[r, j] - c
        hr = H[r % (w1 + 1)]
        if w2 > 0:
            _row_box(a, N0, w1, t1)
            if binom:
                _row_box(t1, n1, w2, t2)
                for j in range(N):
                    hr[j] = t2[j] + 2 * t2[j + 1] + t2[j + 2]
            else:
                _row_box(t1, n1, w2, hr)
        elif binom:
            _row_box(a, N0, w1, t1)
            for j in range(N):
                hr[j] = t1[j] + 2 * t1[j + 1] + t1[j + 2]
        else:
            _row_box(a, N0, w1, hr)
        # down the columns: box w1 over the rows of H
        if r == 0:
            for j in range(N):
                acc1[j] = hr[j]
        elif r < w1:
            for j in range(N):
                acc1[j] += hr[j]
        else:
            old = H[(r - w1) % (w1 + 1)]
            for j in range(N):
                acc1[j] += hr[j] - old[j]
        if r < w1 - 1:
            continue
        q = r - (w1 - 1)  # the first row of acc1's window
        if w2 > 0:
            v1 = V1[q % (w2 + 1)]
            for j in range(N):
                v1[j] = acc1[j]
            if q == 0:
                for j in range(N):
                    acc2[j] = v1[j]
            elif q < w2:
                for j in range(N):
                    acc2[j] += v1[j]
            else:
                old = V1[(q - w2) % (w2 + 1)]
                for j in range(N):
                    acc2[j] += v1[j] - old[j]
            if q < w2 - 1:
                continue
            p = q - (w2 - 1)
            v2 = acc2
        else:
            p = q
            v2 = acc1
        if binom:
            cur = V2[p % 3]
            for j in range(N):
                cur[j] = v2[j]
            if p < 2:
                continue
            o = p - 2
            r0 = V2[(p - 2) % 3]
            r1 = V2[(p - 1) % 3]
        else:
            o = p
            r0 = v2
            r1 = v2
        # the filtered row o (centre: image row o + b): z = W (x - c) - S
        i = o + b
        if binom:
            for j in range(N):
                zr[j] = Wt * (x[i, j + b] - c) - (r0[j] + 2 * r1[j] + cur[j])
        else:
            for j in range(N):
                zr[j] = Wt * (x[i, j + b] - c) - r0[j]
        rs = 0
        for j in range(N):
            rs += zr[j]
            colsum[j] += zr[j]
        rowsum[o] = rs
        if o == 0:  # the centre of the squares: the first row's mean, rounded
            cz = (2 * rs + N) // (2 * N)
            fcz = float(cz)
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        n4 = N - N % 4
        for j in range(0, n4, 4):
            d0 = float(zr[j]) - fcz
            d1 = float(zr[j + 1]) - fcz
            d2 = float(zr[j + 2]) - fcz
            d3 = float(zr[j + 3]) - fcz
            s0 += d0 * d0
            s1 += d1 * d1
            s2 += d2 * d2
            s3 += d3 * d3
        for j in range(n4, N):
            d0 = float(zr[j]) - fcz
            s0 += d0 * d0
        sq += (s0 + s1) + (s2 + s3)
        if write:
            for j in range(N):
                zout[o, j] = zr[j] * f
    res[0] = sq
    res[1] = cz


def _get():
    global _kernel_c, _loaded, _row_box
    from ares.analysis.kernels import jit

    if jit.avoiding():
        return None
    if not _loaded:
        rb = jit.compiled(_row_box, inline=True)
        if rb is not None:
            _row_box = rb  # (the kernel's global: inlined into it)
        _kernel_c, _loaded = jit.compiled(_kernel), True
    return _kernel_c


def available() -> bool:
    """Whether the kernel runs here (numba installed, not ``ares.analysis.kernels.jit.avoided``)."""
    return _get() is not None


def run(x: np.ndarray, c: int, t, W: int, widths: tuple[int, int], binom: bool, zscale: float | None = None,
        span: int | None = None):
    """(row sums, column sums (int64), sum of (z - cz)^2, cz, z * zscale or None) of the
    valid high-pass z = W (x - c) - S of the 2-D integer image ``x``, summed in type ``t``
    (``emva_spatial._integer_work_type``, with ``span``, the largest |x - c|: z in int32
    when 2 W span fits it); None when the kernel does not apply (numba
    missing or avoided)."""
    k = _get()
    if k is None:
        return None
    x = np.ascontiguousarray(x)
    M0, N0 = x.shape
    w1, w2 = widths
    bb = (w1 - 1) + (w2 - 1 if w2 else 0) + (2 if binom else 0)
    M, N = M0 - bb, N0 - bb
    n1 = N0 - w1 + 1
    a, t1, t2 = np.empty(N0, t), np.empty(n1, t), np.empty(n1, t)
    H, V1, V2 = np.empty((w1 + 1, N), t), np.empty((max(w2, 0) + 1, N), t), np.empty((3, N), t)
    acc1, acc2 = np.empty(N, t), np.empty(N, t)
    rowsum, colsum, res = np.empty(M, np.int64), np.empty(N, np.int64), np.empty(2)
    zout = np.empty((M, N) if zscale is not None else (0, 0))
    zr = np.empty(N, np.int32 if span is not None and 2 * span * W < 2**31 else np.int64)
    k(x, t(c), np.int64(W), w1, w2, binom, a, t1, t2, H, V1, V2, acc1, acc2, zr, rowsum, colsum, zout,
      float(zscale if zscale is not None else 1.0), res)
    return rowsum, colsum, float(res[0]), int(res[1]), (zout if zscale is not None else None)


def warm() -> None:
    """Load (or compile) the kernel for the types ``ares emva`` uses: 32-bit pair sums, 64-bit
    stack sums, each summed in int32 and int64."""
    for dt in (np.int32, np.uint32, np.int64):
        for t in (np.int32, np.int64):
            run(np.zeros((24, 24), dt), 0, t, 308 ** 2, (7, 11), True)
            run(np.zeros((24, 24), dt), 0, t, 25, (5, 0), False, 1.0)
