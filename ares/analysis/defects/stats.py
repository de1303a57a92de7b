"""Per-pixel statistics the classifier consumes, and the candidates' time series.

The classifier never needs a whole stack: pass 1 works on per-pixel mean and temporal
variance maps (which a streaming accumulator can provide), pass 2 (RTS) on the time
series of the few candidate pixels pass 1 flags, which :class:`SeriesCollector` keeps
while frames stream by (or :func:`candidate_series` cuts from a recorded stack).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PixelStats:
    """Per-pixel mean (DN) and temporal variance (DN^2, ddof=1) over ``n_frames`` frames."""

    mean: np.ndarray
    var: np.ndarray
    n_frames: int
    exposure_s: float | None = None
    code_step: float | None = None  # the data's code step (1 DN for integer frames); None: not known

    def __post_init__(self) -> None:
        if self.mean.shape != self.var.shape or self.mean.ndim != 2:
            raise ValueError(f"mean {self.mean.shape} and var {self.var.shape} must be equal 2-D shapes")
        if self.n_frames < 2:
            raise ValueError("per-pixel temporal variance needs at least 2 frames")

    @property
    def shape(self) -> tuple[int, int]:
        return self.mean.shape  # type: ignore[return-value]

    @classmethod
    def from_accumulator(cls, acc, exposure_s: float | None = None) -> "PixelStats":
        """From a streaming ``StackAccumulator`` (``mean_map``, ``temporal_var_map``, ``n_frames``)."""
        return cls(np.asarray(acc.mean_map(), dtype=np.float64), np.asarray(acc.temporal_var_map(), dtype=np.float64),
                   int(acc.n_frames), exposure_s)

    def region(self, rows: slice, cols: slice) -> "PixelStats":
        return PixelStats(self.mean[rows, cols], self.var[rows, cols], self.n_frames, self.exposure_s, self.code_step)


def pixel_stats(stack: np.ndarray, exposure_s: float | None = None, block_rows: int = 4) -> PixelStats:
    """Exact per-pixel mean and variance of an (F, R, C) integer stack.

    Works on row blocks after subtracting the first frame. The sums run in float32 where
    that is exact -- every difference d is an integer and a block's largest sum of d^2
    stays below 2^24, so every partial sum is an exactly representable integer -- and
    are redone in float64 (exact for 16-bit data: |d|^2 * F < 2^53) where it is not.
    """
    stack = np.asarray(stack)
    if stack.ndim != 3:
        raise ValueError(f"expected an (F, R, C) stack, got shape {stack.shape}")
    f, r, c = stack.shape
    if f < 2:
        raise ValueError("per-pixel temporal variance needs at least 2 frames")
    mean = np.empty((r, c))
    var = np.empty((r, c))
    exact32 = stack.dtype.kind in "ui" and stack.dtype.itemsize <= 2
    for r0 in range(0, r, block_rows):
        blk = stack[:, r0:r0 + block_rows]
        s1 = s2 = None
        if exact32:
            ref = blk[0].astype(np.float32)
            d = blk.astype(np.float32)
            d -= ref
            s1 = d.sum(axis=0, dtype=np.float32)
            np.multiply(d, d, out=d)
            s2 = d.sum(axis=0, dtype=np.float32)
            if not float(s2.max(initial=0.0)) < 2.0**24:
                s1 = None
        if s1 is None:
            ref = blk[0].astype(np.float64)
            d = blk.astype(np.float64)
            d -= ref
            s1 = d.sum(axis=0)
            np.multiply(d, d, out=d)
            s2 = d.sum(axis=0)
        s1 = s1.astype(np.float64)
        s2 = s2.astype(np.float64)
        mean[r0:r0 + block_rows] = ref + s1 / f
        var[r0:r0 + block_rows] = np.maximum(s2 - s1 * s1 / f, 0.0) / (f - 1)
    return PixelStats(mean, var, f, exposure_s, 1.0 if stack.dtype.kind in "ui" else None)


def candidate_series(stack: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Time series (F, n) of the pixels (rows[i], cols[i]) of a recorded stack."""
    return np.asarray(stack)[:, rows, cols]


class SeriesCollector:
    """Keeps the time series of a fixed set of candidate pixels while frames stream by.

    Memory is O(frames * candidates): run pass 1 (statistics), pick the candidates, then
    feed this collector during a second pass (or a second acquisition).
    """

    def __init__(self, rows: np.ndarray, cols: np.ndarray) -> None:
        self.rows = np.asarray(rows, dtype=np.intp)
        self.cols = np.asarray(cols, dtype=np.intp)
        self._chunks: list[np.ndarray] = []

    @classmethod
    def from_series(cls, rows, cols, series) -> "SeriesCollector":
        """A collector holding an (F, n) series already collected (e.g. read back from a run)."""
        col = cls(rows, cols)
        col._chunks = list(np.asarray(series, dtype=np.float64))
        return col

    def add(self, frame: np.ndarray) -> None:
        self._chunks.append(np.asarray(frame)[self.rows, self.cols].copy())

    @property
    def n_frames(self) -> int:
        return len(self._chunks)

    def region(self, rows: slice, cols: slice, shape: tuple[int, int]) -> "SeriesCollector":
        """The pixels inside a region (row/col slices of a frame of ``shape``), in the
        region's local coordinates -- for per-region/channel classification."""
        r0, r1, rs = rows.indices(shape[0])
        c0, c1, cs = cols.indices(shape[1])
        sel = ((self.rows >= r0) & (self.rows < r1) & ((self.rows - r0) % rs == 0)
               & (self.cols >= c0) & (self.cols < c1) & ((self.cols - c0) % cs == 0))
        sub = SeriesCollector((self.rows[sel] - r0) // rs, (self.cols[sel] - c0) // cs)
        sub._chunks = [c[sel] for c in self._chunks]
        return sub

    @property
    def series(self) -> np.ndarray:
        if not self._chunks:
            return np.empty((0, self.rows.size))
        return np.stack(self._chunks)


def masked_population_stats(stats: PixelStats, defect_mask: np.ndarray) -> dict[str, float]:
    """Population estimates over the pixels NOT in ``defect_mask`` (True = defective).

    Returns the mean signal, the mean per-pixel temporal variance and its standard error,
    and the DSNU variance (spatial variance of the mean map minus temporal/F) -- the
    quantities defects would otherwise bias.
    """
    good = ~np.asarray(defect_mask, dtype=bool)
    n = int(good.sum())
    if n < 2:
        raise ValueError("fewer than 2 good pixels left after masking defects")
    m = stats.mean[good]
    v = stats.var[good]
    f = stats.n_frames
    tvar = float(v.mean())
    spatial = float(m.var(ddof=1))
    return {
        "n_pixels": n,
        "mean_dn": float(m.mean()),
        "mean_se_dn": float(np.sqrt(spatial / n)),
        "temporal_var_dn2": tvar,
        "temporal_var_se_dn2": float(v.std(ddof=1) / np.sqrt(n)),
        "dsnu_var_dn2": spatial - tvar / f,
    }
