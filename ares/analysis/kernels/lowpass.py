"""The EMVA 1288 low-pass (Linear 4.0 Section 8.1; 3.1 Appendix C.5, Eq. 84) in one numba
kernel (``ares.jit``), for ``emva_spatial.smooth``.

For float images (a scan smooths hundreds: every stage's masked non-uniformity): ~1.8 ms
a VGA image against ~2.3 ms for the numpy path's float64 box sums (more with reflected
borders, which pad at every pass). Here each pass is a running sum over a float64 buffer:
box filters cost two additions a pixel whatever their width. Integer images (a pair's or
a stack's exact sum) take the numpy path's exact int32 sums instead (~1 ms). (``ares
emva``, one data set, does not load numba: its import and first load would cost more than
the kernel saves there; ``ares.analysis.kernels.jit.avoided``.)

Borders are scipy's ``reflect`` (half-sample symmetric), applied at every pass like the
numpy path, so the full-size result equals it within float64 rounding (tested). Pixels
the filters reach completely (the ``valid`` crop) never see a reflected value in either
path."""

from __future__ import annotations

import numpy as np

_kernel_c = None
_loaded = False


def _kernel(x, m, out, tmp, w1, w2, binomial):
    """Smooth ``x - m`` (M, N float64; ``m`` its mean, for precision) into ``out``: box
    ``w1``, box ``w2`` (0: none) and the 3-tap binomial (if ``binomial``) along axis 0,
    then the same along axis 1; ``tmp`` is a buffer of x's shape. Widths are odd and at
    most the image's size."""
    M, N = x.shape
    src = x
    c = m  # subtracted while reading x (the first pass), not by a centred copy of it
    # axis 0: whole rows at a time (the inner loops run along contiguous memory)
    acc = np.empty(N)
    bufs = (out, tmp)
    k = 0
    for w in (w1, w2):
        if w == 0:
            continue
        dst = bufs[k % 2]
        h = w // 2
        inv = 1.0 / w
        for j in range(N):
            acc[j] = 0.0
        for r in range(-h, h + 1):
            rr = -r - 1 if r < 0 else (2 * M - r - 1 if r >= M else r)
            for j in range(N):
                acc[j] += src[rr, j] - c
        for j in range(N):
            dst[0, j] = acc[j] * inv
        for i in range(1, M):
            ra = i + h
            ra = 2 * M - ra - 1 if ra >= M else ra
            rs = i - h - 1
            rs = -rs - 1 if rs < 0 else rs
            for j in range(N):
                acc[j] += src[ra, j] - src[rs, j]
                dst[i, j] = acc[j] * inv
        src = dst
        c = 0.0
        k += 1
    if binomial:
        dst = bufs[k % 2]
        for i in range(M):
            ia = i - 1 if i > 0 else 0
            ib = i + 1 if i < M - 1 else M - 1
            for j in range(N):
                dst[i, j] = 0.25 * src[ia, j] + 0.5 * src[i, j] + 0.25 * src[ib, j]
        src = dst
        k += 1
    # axis 1: one row at a time through a reflected copy of it
    for w in (w1, w2):
        if w == 0:
            continue
        dst = bufs[k % 2]
        h = w // 2
        inv = 1.0 / w
        line = np.empty(N + 2 * h + 1)
        for i in range(M):
            for j in range(-h - 1, N + h):
                jj = -j - 1 if j < 0 else (2 * N - j - 1 if j >= N else j)
                line[j + h + 1] = src[i, jj]
            a = 0.0
            for j in range(1, w + 1):
                a += line[j]
            dst[i, 0] = a * inv
            for j in range(1, N):
                a += line[j + w] - line[j]
                dst[i, j] = a * inv
        src = dst
        k += 1
    if binomial:
        dst = bufs[k % 2]
        for i in range(M):
            dst[i, 0] = 0.75 * src[i, 0] + 0.25 * src[i, 1]
            for j in range(1, N - 1):
                dst[i, j] = 0.25 * src[i, j - 1] + 0.5 * src[i, j] + 0.25 * src[i, j + 1]
            dst[i, N - 1] = 0.25 * src[i, N - 2] + 0.75 * src[i, N - 1]
        src = dst
        k += 1
    if k % 2 == 0:  # the last pass wrote tmp
        for i in range(M):
            for j in range(N):
                out[i, j] = tmp[i, j]


def smooth_full(x: np.ndarray, m: float, widths: tuple[int, int], binomial: bool) -> np.ndarray | None:
    """``x - m`` (x 2-D float64, m its mean) smoothed at full size with reflected borders,
    or None when the kernel does not apply (numba missing, image smaller than a filter)."""
    global _kernel_c, _loaded
    from ares.analysis.kernels import jit

    if jit.avoiding():  # (ares emva: not worth loading numba for)
        return None
    if not _loaded:
        _kernel_c, _loaded = jit.compiled(_kernel), True
    M, N = x.shape
    if _kernel_c is None or min(M, N) < max(max(widths), 3):
        return None
    x = np.ascontiguousarray(x, np.float64)
    out = np.empty_like(x)
    _kernel_c(x, float(m), out, np.empty_like(x), widths[0], widths[1], binomial)
    return out


def warm() -> None:
    """Load (or compile) the kernel now (the runner, before a scan: not in the first lit
    stage's analysis, beside its frames)."""
    x = np.zeros((16, 16))
    smooth_full(x, 0.0, (7, 11), True)
