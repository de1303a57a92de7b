"""EMVA 1288 Release 4.0 Linear, the graph data of Sections 8.6 - 8.8.

* ``spectrogram``: horizontal (per row) or vertical (per column) power spectrum, Eqs. 70 -
  71, scaled so that white noise is flat at its variance; the square root is drawn against
  the spatial frequency up to Nyquist. ``pattern_amplitude`` is Eq. 72.
* ``profiles``: middle / mean / max / min profiles of the unfiltered image (Section 8.7)
  and the plot ranges the text asks for.
* ``log_histogram``: bins of width I/L (Eqs. 73 - 75) of an averaged, high-pass filtered
  image, and the normal density for comparison (Eq. 76; the text's s_nw is the
  non-whiteness-based sigma dropped in Release 3.1, Appendix D.1 item 4: ARES uses the
  image's own spatial standard deviation).
* ``accumulated_histogram``: the histogram of |y - mu| (Eqs. 77 - 80) summed from the top
  (Eq. 81), in pixels and in percent.

Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAX_BINS = 256


@dataclass(frozen=True)
class Spectrogram:
    freq: np.ndarray  # cycles per pixel, 0 .. 0.5
    sqrt_power: np.ndarray  # sqrt(P[v]) in the image's unit (DN, or % when relative)
    lines: int = 0  # how many lines (rows or columns) the power is the mean of


def spectrogram(img: np.ndarray, direction: str = "horizontal", scale: float = 1.0) -> Spectrogram:
    """sqrt of the mean power spectrum of the rows (horizontal) or the columns (vertical),
    Eqs. 70 - 71, after subtracting the image mean; values multiplied by ``scale``."""
    y = np.asarray(img, np.float64)
    if direction == "vertical":
        y = y.T
    elif direction != "horizontal":
        raise ValueError(f"direction is 'horizontal' or 'vertical', not {direction!r}")
    n = y.shape[1]
    f = np.fft.rfft(y, axis=1)  # Eq. 70 (times sqrt(N)); the image mean is taken out of the
    f[:, 0] -= float(y.mean()) * n  # v = 0 bin, where it is all (no centred copy of the image)
    p = np.einsum("ij,ij->j", f.real, f.real) + np.einsum("ij,ij->j", f.imag, f.imag)
    p /= y.shape[0] * n  # Eq. 71: the mean over the lines of |F(v)|^2 / N (v = 0 .. N/2)
    return Spectrogram(np.arange(p.size) / n, np.sqrt(p) * scale, y.shape[0])


def pattern_amplitude(power: np.ndarray, n: int, vmin: int, vmax: int) -> float:
    """Amplitude of a periodic pattern from the power spectrum bins vmin..vmax (Eq. 72)."""
    return 2.0 * math.sqrt(float(np.sum(power[vmin:vmax + 1])) / n)


@dataclass(frozen=True)
class Peak:
    freq: float  # cycles/pixel of the strongest bin
    bins: tuple[int, int]  # first and last bin summed
    amplitude: float  # Eq. 72 over the whole peak, noise power taken out (unit of the spectrogram)
    noise_amplitude: float  # the same sum of the noise level alone: what noise bins of that width give
    ratio: float  # strongest bin's power / the local noise level
    p_false: float  # chance that noise alone puts a bin this high anywhere in the spectrum


def _noise_level(p: np.ndarray, mask: np.ndarray, half: int) -> np.ndarray:
    """Running median of the power over +-half bins, bins in ``mask`` (peaks) left out."""
    q = np.where(mask, np.nan, p)
    out = np.empty_like(p)
    for v in range(p.size):
        w = q[max(1, v - half): v + half + 1]
        out[v] = np.nanmedian(w) if np.isfinite(w).any() else np.nanmedian(q[1:])
    return out


def spectrum_peaks(s: Spectrogram, false_alarm: float = 0.01, max_peaks: int = 4) -> list[Peak]:
    """Periodic patterns in a spectrogram (Section 8.6) above its noise.

    Noise: with the power the mean over M independent lines, a noise bin's power over its
    expectation is Gamma(M, 1/M) distributed (each line's |F(v)|^2 is exponential). The
    expectation is taken as the running median of the power (peaks left out, twice). A bin is
    a peak when noise alone would exceed it with probability ``false_alarm`` over the whole
    spectrum (Bonferroni over the bins 1 .. N/2). Its amplitude is Eq. 72 over all the
    contiguous bins of the peak above the noise level (a pattern between two bins leaks into
    its neighbours: the walk goes on while a bin is above the level noise exceeds in 10 % of
    bins), each bin's noise level subtracted."""
    from scipy.stats import gamma

    p = np.asarray(s.sqrt_power, float) ** 2
    m = max(int(s.lines), 1)
    n = 2 * (p.size - 1)
    nb = p.size - 1
    if nb < 3:
        return []
    half = max(8, nb // 16)
    shape = np.full(p.size, float(m))
    shape[-1] = m / 2  # the Nyquist bin of a line is real: one degree of freedom per line, not two
    thr = gamma.isf(false_alarm / nb, shape, scale=1.0 / shape)
    lo_thr = gamma.isf(0.1, shape, scale=1.0 / shape)  # where a peak's flank ends: back into the noise
    mask = np.zeros(p.size, bool)
    mask[0] = True
    for _ in range(3):
        level = _noise_level(p, mask, half)
        hot = (p > thr * level) & (np.arange(p.size) > 0)
        new = mask.copy()
        for v in np.flatnonzero(hot):
            a = v
            while a > 1 and p[a - 1] > lo_thr[a - 1] * level[a - 1]:
                a -= 1
            b = v
            while b < nb and p[b + 1] > lo_thr[b + 1] * level[b + 1]:
                b += 1
            new[a:b + 1] = True
        if np.array_equal(new, mask):
            break
        mask = new
    level = _noise_level(p, mask, half)
    peaks: list[Peak] = []
    seen = np.zeros(p.size, bool)
    for v in np.argsort(p[1:])[::-1] + 1:
        if seen[v] or not p[v] > thr[v] * level[v] or not level[v] > 0:
            continue
        a = v
        while a > 1 and not seen[a - 1] and p[a - 1] > lo_thr[a - 1] * level[a - 1]:
            a -= 1
        b = v
        while b < nb and not seen[b + 1] and p[b + 1] > lo_thr[b + 1] * level[b + 1]:
            b += 1
        seen[a:b + 1] = True
        w = np.where(np.arange(a, b + 1) == nb, 0.25, 1.0)  # Nyquist: p = A^2 N there, not A^2 N / 4
        excess = float(np.sum(w * (p[a:b + 1] - level[a:b + 1])))
        ratio = float(p[v] / level[v])
        pf = min(1.0, nb * float(gamma.sf(ratio, shape[v], scale=1.0 / shape[v])))
        peaks.append(Peak(float(s.freq[v]), (int(a), int(b)), 2.0 * math.sqrt(max(excess, 0.0) / n),
                          2.0 * math.sqrt(float(np.sum(w * level[a:b + 1])) / n), ratio, pf))
        if len(peaks) >= max_peaks:
            break
    return peaks


def profiles(img: np.ndarray, direction: str = "horizontal") -> dict[str, np.ndarray]:
    """Section 8.7: the middle line (row M//2 or column N//2), and the mean, max and min over
    all rows (horizontal) or columns (vertical), of the unfiltered image."""
    y = np.asarray(img, np.float64)
    if direction == "vertical":
        y = y.T
    return {"middle": y[y.shape[0] // 2].copy(), "mean": y.mean(axis=0), "max": y.max(axis=0),
            "min": y.min(axis=0)}


def profile_range(prof: dict[str, np.ndarray], kind: str) -> tuple[float, float]:
    """Plot range of Section 8.7: DSNU 0.9 x mean(min line) .. 1.1 x mean(max line);
    PRNU 0.9 .. 1.1 x mean(mean line)."""
    if kind == "dsnu":
        return 0.9 * float(prof["min"].mean()), 1.1 * float(prof["max"].mean())
    m = float(prof["mean"].mean())
    return 0.9 * m, 1.1 * m


@dataclass(frozen=True)
class Histogram:
    centers: np.ndarray  # bin centres as deviation from the mean (DN)
    counts: np.ndarray  # pixels per bin (int64)
    width: float  # I / L, DN
    model: np.ndarray  # normal density (Eq. 76) per bin, pixels
    sigma: float  # the model's standard deviation, DN


def _bins(span: float, L: int) -> tuple[int, int]:
    I = int(math.floor(L * span / MAX_BINS)) + 1  # Eqs. 73 / 78
    Q = int(math.floor(L * span / I)) + 1
    return I, Q


def _bin_index(t: np.ndarray, L: int, I: float, Q: int) -> np.ndarray:
    """floor(L t / I + 1e-9) clipped to 0 .. Q - 1 (Eqs. 74, 79), in place in ``t`` (a
    temporary of the caller's): one image-sized float64 and one int copy, not five."""
    t *= L
    t /= I
    t += 1e-9
    np.floor(t, out=t)
    np.clip(t, 0, Q - 1, out=t)
    return t.astype(np.intp)


def log_histogram(img: np.ndarray, L: int) -> Histogram:
    """Eqs. 73 - 76 for an averaged (L images), high-pass filtered image."""
    y = np.asarray(img, np.float64).ravel()
    mu = float(y.mean())
    ymin, ymax = float(y.min()), float(y.max())
    I, Q = _bins(ymax - ymin, L)
    counts = np.bincount(_bin_index(y - ymin, L, I, Q), minlength=Q)  # Eq. 74
    centers = ymin + (I - 1) / (2 * L) + np.arange(Q) * I / L - mu  # Eq. 75, relative to the mean
    s = float(y.std())
    model = (I / L) * y.size / (math.sqrt(2 * math.pi) * s) * np.exp(-centers**2 / (2 * s * s)) if s > 0 \
        else np.zeros(Q)  # Eq. 76
    return Histogram(centers, counts, I / L, model, s)


@dataclass(frozen=True)
class Accumulated:
    deviation: np.ndarray  # |y - mu| at the bin centres, DN
    count: np.ndarray  # pixels deviating by at least that much (Eq. 81)
    percent: np.ndarray


def accumulated_histogram(img: np.ndarray, L: int) -> Accumulated:
    """Eqs. 77 - 81: the histogram of |y - mu| summed from the top."""
    y = np.asarray(img, np.float64).ravel()
    d = y - y.mean()
    np.abs(d, out=d)  # Eq. 77
    I, Q = _bins(float(d.max()), L)
    h = np.bincount(_bin_index(d, L, I, Q), minlength=Q)  # Eq. 79
    H = np.cumsum(h[::-1])[::-1]  # Eq. 81
    return Accumulated((I - 1) / (2 * L) + np.arange(Q) * I / L, H, 100.0 * H / y.size)  # Eq. 80
