"""Robust statistics shared by the defect classifiers (median, MAD, line offsets, background)."""

from __future__ import annotations

import numpy as np

from ares.analysis.stats.median import fast_median

MAD_TO_SIGMA = 1.4826  # sigma = 1.4826 * MAD for a Gaussian


def sampled_median(x: np.ndarray, max_samples: int = 1 << 19) -> float:
    """Median of at most ``max_samples`` regularly strided values of ``x`` (a population
    level, not a per-pixel decision: its sampling error, ~1.25 sigma / 724, is negligible)."""
    x = np.asarray(x).ravel()
    if x.size > max_samples:
        x = x[:: -(-x.size // max_samples)]
    return float(fast_median(x))


def robust_sigma(x: np.ndarray, floor: float = 0.0, max_samples: int = 1 << 19) -> float:
    """1.4826 * MAD, from at most ``max_samples`` regularly strided values (a 2^19-pixel
    sample pins the MAD to ~0.2 %, far below what any threshold needs)."""
    x = np.asarray(x, dtype=np.float64).ravel()
    if x.size > max_samples:
        x = x[:: -(-x.size // max_samples)]
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float("nan")
    med = fast_median(x)
    return max(MAD_TO_SIGMA * float(fast_median(np.abs(x - med))), floor)


def remove_lines(img: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Split ``img`` into level + column offsets + row offsets + residual, by medians.

    Returns (residual, col_offsets, row_offsets, level); the residual is what a pixel
    deviates from its own row and column -- immune to column/row fixed-pattern noise.
    """
    level = sampled_median(img)
    a = img - level
    col = fast_median(a, axis=0)
    a = a - col[None, :]
    row = fast_median(a, axis=1)
    a -= row[:, None]
    return a, col, row, level


def _interp_matrix(n: int, centers: np.ndarray) -> np.ndarray:
    """(n, len(centers)) weights of linear interpolation (extrapolated beyond the ends)."""
    x = np.arange(n, dtype=np.float64)
    m = len(centers)
    w = np.zeros((n, m))
    if m == 1:
        w[:, 0] = 1.0
        return w
    j = np.clip(np.searchsorted(centers, x) - 1, 0, m - 2)
    t = (x - centers[j]) / (centers[j + 1] - centers[j])  # linear extrapolation at the edges
    w[np.arange(n), j] = 1.0 - t
    w[np.arange(n), j + 1] = t
    return w


def block_median_background(img: np.ndarray, block: int) -> np.ndarray:
    """Local median background: medians of ``block`` x ``block`` tiles, bilinearly interpolated.

    A fast stand-in for a sliding median filter: a defect (or a small cluster) cannot move
    a tile median, and smooth illumination gradients are followed.
    """
    r, c = img.shape
    b_r, b_c = min(block, r), min(block, c)
    nr, nc = -(-r // b_r), -(-c // b_c)
    padded = np.pad(img, ((0, nr * b_r - r), (0, nc * b_c - c)), mode="reflect" if min(r, c) > 1 else "edge")
    tiles = padded.reshape(nr, b_r, nc, b_c).transpose(0, 2, 1, 3).reshape(nr, nc, b_r * b_c)
    med = fast_median(tiles, axis=2)
    rc = np.minimum(np.arange(nr) * b_r + (b_r - 1) / 2.0, r - 1)
    cc = np.minimum(np.arange(nc) * b_c + (b_c - 1) / 2.0, c - 1)
    return _interp_matrix(r, rc) @ med @ _interp_matrix(c, cc).T


def structure_ratio(res: np.ndarray, max_samples: int = 1 << 19) -> float:
    """Robust sigma of ``res`` over the robust sigma of its horizontal first differences
    / sqrt(2): ~1 for spatially white residuals, > 1 where smooth or periodic structure
    (shading, glow, a patterned dark) is left after the row/column medians."""
    if res.shape[1] < 2:
        return 1.0
    d = np.diff(res, axis=1) / np.sqrt(2.0)
    s_d = robust_sigma(d, max_samples=max_samples)
    s_r = robust_sigma(res, max_samples=max_samples)
    return s_r / s_d if s_d > 0 else 1.0


def local_background(res: np.ndarray, size: int = 5) -> np.ndarray:
    """A separable ``size`` x ``size`` running median (rows, then columns) that leaves the
    pixel itself out (a ring of ``size - 1`` neighbours per pass): follows any structure
    wider than ~size pixels, smooth or periodic, while a single defect pixel (or a 2-pixel
    cluster) cannot move it. Leaving the pixel out keeps its residual's tails Gaussian
    with its core: a median that includes the pixel narrows the core (MAD) but not the
    tails, and a 4.8-sigma threshold then gives 10x the false alarms. 0.14 s at 1080p."""
    from scipy import ndimage

    if min(res.shape) < size:
        return np.zeros_like(res)
    ring = np.ones(size, bool)
    ring[size // 2] = False
    k = size // 2  # ranks k-1 and k: the two middle values of the size-1 neighbours

    def median(x, footprint):  # an even count: the mean of the two middle values (scipy's
        # median_filter takes the upper one, biased up by ~0.3 sigma and up a gradient)
        # "nearest" at the borders: a reflected edge makes a local extremum of any gradient
        return 0.5 * (ndimage.rank_filter(x, k - 1, footprint=footprint, mode="nearest")
                      + ndimage.rank_filter(x, k, footprint=footprint, mode="nearest"))

    return median(median(res, ring[None, :]), ring[:, None])
