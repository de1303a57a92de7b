"""EMVA 1288 Release 4.0 Linear, spatial nonuniformity (Sections 4.2, 4.3, 8.1 - 8.3, 8.5).

* ``highpass``: the Release 4.0 correction for uneven illumination (Section 8.1): the image
  smoothed by a 7x7 box, an 11x11 box and a 3x3 binomial filter, one after the other, is
  subtracted from it. Only the pixels the filters reach completely are kept (9 rows and
  columns at each border; the text states the border rule for the 3.1 filter, Appendix
  C.5, and ARES applies it to the 4.0 kernel's half width). ``release="3.1"`` is the 5x5
  box of Appendix C.5 (Eq. 84), border 2.
* ``split``: total, column, row and pixel spatial variances of an averaged image
  (Eqs. 35 - 44) with the residual temporal variance sigma^2 / L removed (Eq. 36); two
  images are the L = 2 case of the same equations (Eq. 32 is var(<y>) - sigma^2/2).
  By default exactly as written: Eq. 36, the white-noise temporal terms of Eqs. 39 - 41
  and the solution Eq. 43. ``Split.extended`` holds ARES's option ``rowcol_corrected``
  (beyond the text, shown beside the text's values, never instead of them): after the
  high-pass, a white pattern keeps only part of its variance: ``g2`` of the pixel and
  temporal parts (the 2-D white-noise gain, 0.9885 for the 4.0 filter) and ``g1`` of a
  column or row pattern (the 1-D gain, ~0.89: the filter also removes the long-wavelength
  share of a white column pattern), and row- or column-correlated temporal noise, when
  measured, is not taken for a pattern; Eq. 42 is solved with these gains and terms (the
  principle of Appendix C.5, Eq. 86, which divides the 3.1 result by 0.96).
* ``nonuniformity``: DSNU1288 (Eq. 66) and PRNU1288 (Eq. 67) and their .row/.col/.pix
  parts (Section 8.3), each with its SE -- the measurement error of THIS sensor's pattern
  from the temporal noise left in the averages (``pattern_se``), not the population's
  sampling spread -- or an upper limit when the variance is not above twice its SE.

Pure numpy (and, where numba is loaded, ``highpass_kernel``: the same exact integer sums
in one streaming pass; ``ares.jit``): no I/O.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.spatial.pattern_se import measurement_se, temporal_parts
from ares.analysis.stats.estimate import Estimate

HIGHPASS_BORDER = {"4.0": 9, "3.1": 2, "none": 0}
LOWPASS = {"4.0": ((7, 11), True), "3.1": ((5, 0), False)}  # box widths, 3-tap binomial (Section 8.1, Eq. 84)


# each pass: (box widths applied one after the other, half width = the edge a pass reads)
_PASSES = {"4.0": (((7,), 3), ((11,), 5), ((2, 2), 1)), "3.1": (((5,), 2),)}


def _box_sums(v: np.ndarray, w: int, step: int) -> np.ndarray:
    """Sums of ``w`` >= 2 samples ``step`` apart, of a flat image (``step`` = its row length:
    along the columns; 1: along the rows, where the last w - 1 sums of each row run into the
    next and the caller drops them), by binary doubling: pairs, quads, ... as whole-array
    slices, then the pieces ``w``'s binary digits name -- log2(w) + popcount(w) - 1
    additions, none per tap, every one over contiguous memory. Exact for integer arrays
    (the caller keeps every sum inside their type). The result may be a view of an array
    made here, never of ``v``."""
    out_len = v.size - (w - 1) * step
    pieces = []
    span, off, rest = 1, 0, w
    while True:
        if rest & 1:
            pieces.append(v[off * step:off * step + out_len])
            off += span
        rest >>= 1
        if not rest:
            break
        n = v.size - span * step
        v = v[:n] + v[span * step:span * step + n]
        span *= 2
    if len(pieces) == 1:
        return pieces[0]
    out = pieces[0] + pieces[1]
    for p in pieces[2:]:
        out += p
    return out


def _rows_of(v: np.ndarray, rows: int, row_len: int, cols: int) -> np.ndarray:
    """The first ``cols`` samples of each of ``rows`` rows of ``row_len`` in the flat ``v``."""
    return np.lib.stride_tricks.as_strided(v, (rows, cols), (row_len * v.itemsize, v.itemsize), writeable=False)


def _lowpass_sums(x: np.ndarray, release: str, border: str) -> tuple[np.ndarray, int]:
    """(S, W): the low-pass of ``x`` as unnormalized sums ``S`` with total weight ``W`` (the
    smoothed image is S / W). Section 8.1: box 7, box 11, the 3-tap binomial (= box 2
    twice), along each axis; Eq. 84: box 5. ``border="reflect"``: each pass sees
    half-sample-symmetric edges, scipy.ndimage's ``reflect``; ``"valid"``: the
    ``HIGHPASS_BORDER`` rows and columns the filters do not reach completely are dropped."""
    W = 1
    for widths, h in _PASSES[release]:  # along the columns (axis 0): shifts by whole rows
        if border == "reflect":
            x = np.pad(x, ((h, h), (0, 0)), mode="symmetric")
        cols = x.shape[1]
        v = np.ascontiguousarray(x).ravel()
        for w in widths:
            v = _box_sums(v, w, cols)
            W *= w
        x = v.reshape(-1, cols)
    rows = x.shape[0]
    if border == "valid":  # along the rows: one flat pass each, the sums across row ends dropped at the end
        cols = x.shape[1]
        v, lost = np.ascontiguousarray(x).ravel(), 0
        for widths, _ in _PASSES[release]:
            for w in widths:
                v = _box_sums(v, w, 1)
                W *= w
                lost += w - 1
        return _rows_of(v, rows, cols, cols - lost), W
    for widths, h in _PASSES[release]:
        x = np.pad(x, ((0, 0), (h, h)), mode="symmetric")  # (a new, contiguous array)
        cols = x.shape[1]
        v = x.ravel()
        for w in widths:
            v = _box_sums(v, w, 1)
            W *= w
        x = _rows_of(v, rows, cols, cols - 2 * h)
    return x, W


def _weight(release: str) -> int:
    """The low-pass's total weight: the product of its box widths, squared (both axes)."""
    return math.prod(w for widths, _ in _PASSES[release] for w in widths) ** 2


def _integer_work_type(x: np.ndarray, W: int):
    """(type, centre, span) to sum an integer image ``x`` in exactly: int32 when W times the
    largest distance from the centre (``span``) fits it (12-bit data always), else int64."""
    lo, hi = int(x.min()), int(x.max())
    c = (lo + hi) // 2
    span = max(hi - c, c - lo)
    return (np.int32 if span * W < 2**31 else np.int64), c, span


# images below this take the numpy path even where numba is loaded: at VGA the kernel saves
# ~1 ms a stage, while loading its compiled code adds ~35 MiB to every run's peak (the
# Runner has numba loaded; ares.scan.preflight's memory model was measured without it)
KERNEL_MIN_PIXELS = 1_000_000


def _kernel_sums(x: np.ndarray, release: str, zscale: float | None = None):
    """``highpass_kernel.run`` for the integer image ``x`` (its row and column sums of the
    exact z = W x - S, the sum of (z - cz)^2, cz, and z * zscale when asked), or None
    where the numpy path is taken: an image below ``KERNEL_MIN_PIXELS``, numba missing or avoided, or sums of z that might not
    fit int64 (the kernel's totals are int64; 2 W span bounds |z|), or uint64 images
    (numba takes uint64 - int64 to float64)."""
    from ares.analysis.kernels.highpass import available, run

    if x.size < KERNEL_MIN_PIXELS or x.dtype == np.uint64 or not available():
        return None
    t, c, span = _integer_work_type(x, _weight(release))
    if 2 * span * _weight(release) * x.size >= 2**63:
        return None

    (w1, w2), binom = LOWPASS[release]
    return run(x, c, t, _weight(release), (w1, w2), binom, zscale, span)


def _check_size(x: np.ndarray, release: str) -> None:
    b = HIGHPASS_BORDER[release]
    if x.shape[0] <= 2 * b + 2 or x.shape[1] <= 2 * b + 2:
        raise ValueError(f"the {release} high-pass needs more than {2 * b + 2} rows and columns, "
                         f"the image has {x.shape[0]} x {x.shape[1]}")


def smooth(img: np.ndarray, release: str = "4.0", border: str = "valid") -> np.ndarray:
    """The low-pass of Section 8.1 (4.0: 7x7 box, 11x11 box, 3x3 binomial) or Eq. 84 (3.1:
    5x5 box), separable, float64. ``border="valid"``: only where the filters need no pixel
    outside the image (``HIGHPASS_BORDER`` dropped); ``"reflect"``: the image's shape,
    reflected edges (for normalized convolution of masked images). The one implementation
    of the EMVA high-pass in ARES (``flat`` and ``masked`` use it too). Integer images are
    summed exactly; float images in float64 after subtracting their mean, as the numba
    kernel (``lowpass``) does: the paths agree within float64 rounding."""
    x = np.asarray(img)
    if release not in _PASSES:
        raise ValueError(f"unknown high-pass release {release!r}")
    if border == "valid":
        _check_size(x, release)
    if x.dtype.kind in "ui" and x.size:
        t, c, _ = _integer_work_type(x, _weight(release))
        S, W = _lowpass_sums(np.subtract(x, c, dtype=t), release, border)
        out = S * (1.0 / W)
        out += c
        return out
    x = np.asarray(x, np.float64)
    m = float(x.mean()) if x.size else 0.0
    from ares.analysis.kernels.lowpass import smooth_full

    y = smooth_full(x, m, *LOWPASS[release])  # numba, float64 throughout
    if y is not None:
        if border == "valid":
            b = HIGHPASS_BORDER[release]
            y = y[b:-b, b:-b]
    else:
        S, W = _lowpass_sums(x - m, release, border)
        y = S * (1.0 / W)
    y += m
    return y


def _highpass_scaled(x: np.ndarray, release: str) -> tuple[np.ndarray, float]:
    """(z, f): the high-passed image is ``z * f``; z is a new float64 array (exact integers
    for an integer image: W x - S, the division by the weight W left to the caller)."""
    if release == "none":
        return np.array(x, np.float64), 1.0  # a copy: callers centre it in place
    _check_size(x, release)
    b = HIGHPASS_BORDER[release]
    if x.dtype.kind in "ui":
        t, c, _ = _integer_work_type(x, _weight(release))
        xc = np.subtract(x, c, dtype=t)
        S, W = _lowpass_sums(xc, release, "valid")
        z = np.multiply(xc[b:-b, b:-b], float(W))  # W x - S: exact in float64 (below 2**53)
        z -= S
        return z, 1.0 / W
    x = np.asarray(x, np.float64)
    return x[b:-b, b:-b] - smooth(x, release), 1.0


def highpass(img: np.ndarray, release: str = "4.0", scale: float = 1.0) -> np.ndarray:
    """Image (times ``scale``) minus its smoothed version (Section 8.1), border rows/columns
    dropped, float64. An integer image (e.g. the sum of a pair or a stack, ``scale`` 1/L) is
    filtered exactly: the only rounding is the final division by the filter's weight and
    the scale. ``release="none"`` returns the image as a float64 copy (the profiles of
    Section 8.7). An integer image is filtered a block of rows at a time (``split``'s blocks:
    each pixel's exact sums are the same, so is the result), its temporaries ~1 MB each --
    a long stack's sum needs int64 sums, and whole-image ones had made ``ares emva``'s peak
    grow with the stack length. Where numba is loaded, ``highpass_kernel`` streams the rows
    instead (the same integers times the same scale: the same bits, tested)."""
    x = np.asarray(img)
    if release == "none" or x.dtype.kind not in "ui":
        z, f = _highpass_scaled(x, release)
        if f * scale != 1.0:
            z *= f * scale
        return z
    _check_size(x, release)
    got = _kernel_sums(x, release, (1.0 / _weight(release)) * scale)  # (z * f * scale, as below)
    if got is not None:
        return got[4]
    b = HIGHPASS_BORDER[release]
    out = np.empty((x.shape[0] - 2 * b, x.shape[1] - 2 * b))
    for r0, r1 in _row_blocks(out.shape[0], x.shape[1]):
        z, f = _highpass_scaled(x[r0:r1 + 2 * b], release)
        np.multiply(z, f * scale, out=out[r0:r1])
    return out


def _row_blocks(rows: int, row_len: int):
    """(first, end) of the blocks of filtered rows ``split`` and ``highpass`` work in: about
    ``BLOCK_PIXELS`` each, at least 3 rows (what the filter needs)."""
    blocks = max(1, rows // max(3, BLOCK_PIXELS // row_len))
    return zip([rows * i // blocks for i in range(blocks)], [rows * (i + 1) // blocks for i in range(blocks)])


def kernel_1d(release: str) -> np.ndarray:
    if release == "4.0":
        k = np.convolve(np.convolve(np.full(7, 1 / 7), np.full(11, 1 / 11)), [0.25, 0.5, 0.25])
    elif release == "3.1":
        k = np.full(5, 1 / 5)
    else:
        return np.zeros(1)
    return k


@functools.lru_cache(maxsize=None)  # (floats of a release name: every split reads them)
def white_gains(release: str) -> tuple[float, float]:
    """(g1, g2): the share of a white 1-D (row or column) and 2-D pattern's variance that the
    high-pass keeps, sum h^2 for h = delta - smoothing kernel."""
    if release == "none":
        return 1.0, 1.0
    k = kernel_1d(release)
    c = k.size // 2
    g1 = 1.0 - 2.0 * float(k[c]) + float(np.sum(k * k))
    k2 = np.outer(k, k)
    g2 = 1.0 - 2.0 * float(k2[c, c]) + float(np.sum(k2 * k2))
    return g1, g2


@dataclass(frozen=True)
class Split:
    """Spatial variances of one (averaged) image, DN^2, and their SEs (Eqs. 37 - 44): the
    measurement error of this sensor's pattern from the temporal noise left in the average
    (``pattern_se``); ``bias`` what that noise adds beyond what the solve removed (the
    text's white-noise assumption, when row/column temporal variances are measured), which
    the figures' SE holds in quadrature (``std_estimate``)."""

    total: float
    col: float
    row: float
    pix: float
    se_total: float
    se_col: float
    se_row: float
    se_pix: float
    mean: float  # mean of the unfiltered image (Eq. 34)
    rows: int  # M, N after the high-pass border
    cols: int
    L: int
    extended: "Split | None" = None  # ARES option rowcol_corrected (filter gains, row/column temporal noise)
    bias: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # (total, col, row, pix)

    def get(self, part: str) -> tuple[float, float]:
        """(variance, its measurement SE)."""
        return getattr(self, part), getattr(self, "se_" + part)

    def bias_of(self, part: str) -> float:
        return self.bias[("total", "col", "row", "pix").index(part)]


BLOCK_PIXELS = 1 << 17  # ``split`` high-passes an image a block of rows (about this many pixels) at a time


def split(img: np.ndarray, temporal_var: float, L: int, release: str = "4.0", row_var: float | None = None,
          col_var: float | None = None, scale: float = 1.0, mean: float | None = None,
          temporal_var_text: float | None = None) -> Split:
    """Column, row and pixel spatial variances of ``img`` (the average of ``L`` images whose
    pixel temporal variance is ``temporal_var``), after the high-pass of ``release``
    ("4.0", "3.1" or "none"). ``row_var``/``col_var``: the temporal variances of the row and
    column means (frame offset removed) when measured -- then, in ``Split.extended`` (option
    ``rowcol_corrected``), row- and column-correlated temporal noise (which averaging over L
    images leaves as var/L) is not taken for a row or column pattern. The returned split
    itself is Eqs. 36, 39 - 41, 43 as written, with sigma^2 = ``temporal_var_text`` when
    given (Eq. 57's per-pixel temporal variance, frame offsets included), else
    ``temporal_var``.
    ``scale``: the averaged image is ``img * scale`` (an exact integer sum: a pair's 1/2, a
    stack's 1/L). A large image is high-passed a block of rows at a time (each block with
    the ``HIGHPASS_BORDER`` rows the filter reads around it; the valid filter reads nothing
    outside it, so the sums are those of the whole filtered image): a block's temporaries
    are ~1 MB each (an int32 block stays in a core's L2 cache), a 12 Mpx frame's are not
    100 MB. ``ares emva``, whose two threads split a VGA pair in two blocks instead of one:
    peak memory 62 -> 55 MB, wall time 0.69 -> 0.63 s (medians of 12 interleaved runs;
    blocks of 64 K pixels were slower again: more numpy calls, each holding the GIL).
    ``mean``: the mean of ``img * scale`` when the caller knows it (a pair's, from its
    exact sums).
    Where numba is loaded (``ares.jit``), an integer image takes ``highpass_kernel``
    instead: one streaming pass, no float64 image, exact integer row and column sums of
    the same z; only its float64 sum of squares is added in another order, so the figures
    agree with the numpy path's to ~1e-13 relative (tested)."""
    x = np.asarray(img)
    if mean is None:
        mean = float(x.mean(dtype=np.float64)) * scale
    w, tr, tc = temporal_parts(temporal_var, x.shape[0], x.shape[1], row_var, col_var)
    if release != "none":
        _check_size(x, release)
    b = HIGHPASS_BORDER[release]
    M, N = x.shape[0] - 2 * b, x.shape[1] - 2 * b
    got = _kernel_sums(x, release) if release != "none" and x.dtype.kind in "ui" else None
    if got is not None:  # exact integer row and column sums of z; the squares about cz
        rs, cs, sq, cz, _ = got
        f = 1.0 / _weight(release)
        d = (int(rs.sum()) - cz * M * N) / (M * N)  # the mean of z - cz
        col_means = (cs - cz * M) / M
        row_means = (rs - cz * N) / N
    else:
        col_sums, row_means, sq, c0 = np.zeros(N), np.empty(M), 0.0, None
        for r0, r1 in _row_blocks(M, x.shape[1]):
            z, f = _highpass_scaled(x[r0:r1 + 2 * b], release)  # rows r0..r1 of the filtered image, / (f * scale)
            if c0 is None:  # sums about the first block's mean: no cancellation whatever the offset
                c0 = float(z.mean())
            z -= c0
            col_sums += z.sum(axis=0)
            row_means[r0:r1] = z.mean(axis=1)
            sq += float(np.dot(z.ravel(), z.ravel()))
        col_means = col_sums / M
        d = float(col_means.mean())  # the mean minus c0 (every column has M pixels)
    f2 = (f * scale) ** 2
    w, tr, tc = w / L, tr / L, tc / L  # residual temporal variance of the average (Eq. 36)
    s2_meas = (sq / (M * N) - d * d) * f2  # Eq. 35
    col_means -= d
    cav = float(np.dot(col_means, col_means)) / N * f2  # Eq. 41 (before the temporal term)
    row_means -= d
    rav = float(np.dot(row_means, row_means)) / M * f2
    g1, g2 = white_gains(release)
    # the SEs' noise (both solves): what the measured temporal variances say is left in the average
    noise = (max(w, 0.0), max(tr, 0.0), max(tc, 0.0), max(L - 1, 1) * x.size, g1, g2)
    text = _solve(cav, rav, s2_meas, M, N, L, mean, 1.0, 1.0,
                  (temporal_var if temporal_var_text is None else temporal_var_text) / L, 0.0, 0.0, noise)
    ext = _solve(cav, rav, s2_meas, M, N, L, mean, g1, g2, w, tr, tc, noise)
    return dataclasses.replace(text, extended=ext)


def _solve(cav: float, rav: float, s2_meas: float, M: int, N: int, L: int, mean: float, g1: float, g2: float,
           w: float, tr: float, tc: float, noise: "tuple[float, float, float, float, float, float] | None" = None
           ) -> Split:
    """Eq. 42 for (col, row, pix) from the measured column- and row-mean variances and the
    total (Eqs. 35, 41) with the residual temporal variances of the average (white ``w``,
    row- and column-correlated ``tr``, ``tc``) removed; ``g1``/``g2`` the high-pass gains
    of a 1-D and a 2-D white pattern. With g = 1 and tr = tc = 0: Eqs. 36, 39 - 41 and 43
    as written. ``noise``: the temporal noise left in the average (white, row, column), the
    dof of the subtracted ``w`` and the filter's gains (h1, h2), for the SEs and the bias."""
    A = np.array([[g1, 0.0, g1 / M], [0.0, g1, g1 / N], [g1, g1, g2]])
    b = np.array([cav - g1 * (tc + w / M), rav - g1 * (tr + w / N), s2_meas - g2 * w - g1 * (tr + tc)])
    col, row, pix = np.linalg.solve(A, b)
    tot = col + row + pix  # Eq. 37
    if noise is None:
        noise = (w, tr, tc, max(L - 1, 1) * M * N, g1, g2)
    nw, ntr, ntc, dof, h1, h2 = noise
    se = measurement_se(A, (g1 / M, g1 / N, g2), w, cav, rav, s2_meas, M, N, nw, ntr, ntc, dof, (h1, h2))
    # the bias: what that noise adds to each part beyond what the solve removes (Eqs. 39 - 41:
    # row/column temporal noise; Eq. 57's frame offsets; the high-pass's share of white noise)
    nb = np.array([h1 * (ntc + nw / M), h1 * (ntr + nw / N), h2 * nw + h1 * (ntr + ntc)])
    bias = np.linalg.solve(A, nb - (cav - b[0], rav - b[1], s2_meas - b[2]))
    return Split(float(tot), float(col), float(row), float(pix), *se, mean, M, N, L,
                 bias=(float(bias.sum()), *(float(x) for x in bias)))


PARTS = (("total", ""), ("col", ".col"), ("row", ".row"), ("pix", ".pix"))


def std_estimate(s2: float, se2: float, scale: float, scale_rel_se: float, unit: str, note: str,
                 bias2: float = 0.0) -> Estimate:
    """sqrt(s2) * scale with its SE; an upper limit when s2 is not above 2 SE. ``se2``: the
    variance's measurement SE (``Split``, ``pattern_se``): whether the data resolve it from
    0. ``bias2``: what the estimator's own assumptions leave in it, measured (``Split.bias``:
    Eqs. 39 - 41's white temporal noise against the measured row/column noise) -- the value
    is kept as the text writes it, and the SE holds it in quadrature, said in the note."""
    if not math.isfinite(s2):
        return Estimate.na("spatial variance not available", unit)
    if s2 <= 2 * se2:  # (a text's over-subtraction, bias2 < 0, raises the bound: it must hold the pattern's)
        return Estimate.limit(math.sqrt(max(s2 - min(bias2, 0.0), 0.0) + 2 * se2) * scale, "upper", unit,
                              note + f"; variance {s2:.3g} +- {se2:.2g} DN^2 is not above 2 SE" +
                              (f" (bias {bias2:+.2g} DN^2 of the text's Eqs. 36, 39 - 41 in the bound)"
                               if bias2 < -0.1 * se2 else ""))
    s = math.sqrt(s2)
    if abs(bias2) > 0.1 * se2:
        note += (f"; SE holds {bias2:+.2g} DN^2 the temporal noise left in the average adds beyond what the text's "
                 f"Eqs. 36, 39 - 41 remove (measured; option rowcol_corrected removes it)")
    return Estimate(s * scale, s * scale * math.hypot(math.hypot(se2, bias2) / (2 * s2), scale_rel_se), unit, note)


def dsnu(dark: Split, K: float, K_se: float) -> dict[str, Estimate]:
    """DSNU1288 and its .col/.row/.pix parts in e- (Eq. 66), and the total in DN."""
    out = {}
    for part, suffix in PARTS:
        s2, se2 = dark.get(part)
        out["DSNU1288" + suffix.replace(".", "_")] = std_estimate(
            s2, se2, 1.0 / K, K_se / K, "e-", f"s_y.dark{suffix} / K (EMVA 1288 4.0 Linear Eq. 66)",
            dark.bias_of(part))
    s2, se2 = dark.get("total")
    out["DSNU1288_DN"] = std_estimate(s2, se2, 1.0, 0.0, "DN", "s_y.dark (Eq. 66 x K)", dark.bias_of("total"))
    return out


def prnu(bright: Split, dark: Split) -> dict[str, Estimate]:
    """PRNU1288 and its parts in % (Eq. 67): sqrt(s2_y.50 - s2_y.dark) / (mu_y.50 - mu_y.dark)."""
    sig = bright.mean - dark.mean
    out = {}
    for part, suffix in PARTS:
        b, bse = bright.get(part)
        d, dse = dark.get(part)
        key = "PRNU1288" + suffix.replace(".", "_")
        if sig <= 0:
            out[key] = Estimate.na("the bright stack is not above the dark stack", "%")
            continue
        out[key] = std_estimate(b - d, math.hypot(bse, dse), 100.0 / sig, 0.0, "%",
                                 f"sqrt(s2_y.50{suffix} - s2_y.dark{suffix}) / (mu_y.50 - mu_y.dark) (Eq. 67)",
                                 bright.bias_of(part) - dark.bias_of(part))
    return out


def snr_total_model(photons: np.ndarray, eta: float, sigma_d_e: float, dsnu_e: float, prnu_frac: float,
                    K: float) -> np.ndarray:
    """Total SNR model (Eq. 69): eta mu_p / sqrt(sigma_d^2 + DSNU^2 + sigma_q^2/K^2 + eta mu_p
    + PRNU^2 (eta mu_p)^2)."""
    e = eta * np.asarray(photons, float)
    return e / np.sqrt(sigma_d_e**2 + dsnu_e**2 + (1 / 12) / K**2 + e + (prnu_frac * e) ** 2)


def snr_model(photons: np.ndarray, eta: float, sigma_d_e: float, K: float) -> np.ndarray:
    """Temporal SNR of the linear model (Eq. 21)."""
    e = eta * np.asarray(photons, float)
    return e / np.sqrt(sigma_d_e**2 + (1 / 12) / K**2 + e)


ROWCOL = "rowcol_corrected"  # the option name of Split.extended


def nonuniformity_rowcol_corrected(dark: Split, bright: Split | None, K: float, K_se: float) -> dict[str, Estimate]:
    """DSNU1288/PRNU1288 and their parts from ``Split.extended`` (ARES option
    ``rowcol_corrected``, beyond the text), keyed ``<key>.rowcol_corrected`` and labelled,
    for showing beside the text's values."""
    out: dict[str, Estimate] = {}
    if dark.extended is None:
        return out
    parts = dsnu(dark.extended, K, K_se)
    if bright is not None and bright.extended is not None:
        parts.update(prnu(bright.extended, dark.extended))
    label = ("ARES option rowcol_corrected, beyond EMVA 1288 4.0 Eqs. 39 - 41: high-pass gains of row/column/pixel "
             "patterns and measured row/column temporal noise removed; ")
    for k, e in parts.items():
        if k == "DSNU1288_DN":
            continue
        e2 = dataclasses.replace(e, note=label + e.note)
        out[f"{k}.{ROWCOL}"] = e2
    return out
