"""Noise decomposition with a fixed defect mask: unbalanced three-way random-effects ANOVA.

A pixel mask ``M`` (True = exclude the pixel's whole time series, e.g. the defect map of
``ares.analysis.defects``) leaves an *incomplete* rows x columns layout of good cells
crossed with all F frames. The balanced ANOVA of ``anova.py`` needs the complete cube;
here the variance components are estimated by the method of moments on the good cells
(Henderson's method I): quadratic forms of good-cell sums whose expectations are derived
for the unequal counts, equated to their observed values and solved. Unbiased for any
mask (no approximation); with an empty mask it reproduces ``decompose_dark`` exactly.

Model on good cells (r, c) (``anova.py``)::

    y[f,r,c] = o + g[f] + Rs[r] + Cs[c] + Rt[f,r] + Ct[f,c] + Ps[r,c] + Pt[f,r,c]

*Temporal part.* Project the frame axis on F-1 orthonormal contrasts u_k: each
``z_k[r,c] = sum_f u_k[f] y[f,r,c]`` is an independent replicate of the two-way model
``a_k + b_kr + c_kc + e_krc`` with variances (fg, Rt, Ct, Pt). With n_r, n_c the good
counts per row/column, N the good total, R', C' the rows/columns holding good cells,
``kr = sum n_r^2/N``, ``kc = sum n_c^2/N``, the forms summed over the replicates are

    T0 = sum_good pixel_SS                     E = (F-1) N (fg + Rt + Ct + Pt)
    TR = sum_r Q_r / n_r                       E = (F-1) (N fg + N Rt + R' Ct + R' Pt)
    TC = sum_c Q_c / n_c                       E = (F-1) (N fg + C' Rt + N Ct + C' Pt)
    Tm = Q_tot / N                             E = (F-1) (N fg + kr Rt + kc Ct + Pt)

with ``Q_r = sum_f (Y_fr - mean_f Y_fr)^2`` of the good-pixel row sums Y_fr (likewise
columns and frame totals). The mean squares ``MS_F = Tm/df_F``, ``MS_FR = (TR-Tm)/df_FR``,
``MS_FC = (TC-Tm)/df_FC``, ``MS_E = (T0-TR-TC+Tm)/df_E`` with df_F = F-1,
df_FR = (F-1)(R'-1), df_FC = (F-1)(C'-1), df_E = (F-1)(N-R'-C'+1) reduce to the balanced
ones when nothing is masked.

*Spatial part.* The time-mean map on good cells is one replicate of the two-way model
with row variance ``Rs + Rt/F``, column ``Cs + Ct/F`` and pixel ``Ps + Pt/F`` (frame mean
and offset are a common constant): the same forms give F*SS_R, F*SS_C, F*SS_RC
(df R'-1, C'-1, N-R'-C'+1).

The 7 expected mean squares are a linear map K of (fg, Rt, Ct, Pt, Rs, Cs, Ps);
``theta = K^-1 MS`` is unbiased. Standard errors as in ``anova.py`` (the mean squares
treated as independent; a temporal one's chi-square, Satterthwaite, a spatial one's given
the sensor's pattern, its noise from K: ``MaskedTable.ms_variances``) with these reduced
degrees of freedom; close to exact for a sparse scattered mask.

Streaming: ``MaskedStackAccumulator(shape, mask)`` keeps per-pixel sums and sums of
squares, per-row and per-column sums of squares over frames of the good-pixel row/column
sums, and the frame totals -- one pass, memory independent of the frame count except the
F frame means (as ``StackAccumulator``), mergeable. Sums are float64 on data shifted by
the first frame (SCIENCE.md "Numerics"). The mask must be known before the frames arrive
(from a previous defect scan, or a first pass over a recorded stack).

``decompose_dark(acc)``, ``anova_table(acc)``, ``decompose_flat(flat, dark)`` and
``StackAnalysis`` dispatch here when given a ``MaskedStackAccumulator``. The forms and
the table themselves are in ``masked_anova.py``.
"""

from __future__ import annotations

import math

import numpy as np

from ares.errors import InputError

from ares.analysis.kernels import masked_fold
from ares.analysis.kernels import recycle
from ares.analysis.stats.estimate import Estimate
from ares.analysis.noise.masked_anova import MaskedTable, henderson_two_way, masked_table
from ares.analysis.noise.masked_decompose import decompose_dark_masked, decompose_flat_masked

__all__ = ["MaskedStackAccumulator", "MaskedTable", "masked_table", "decompose_dark_masked",
           "decompose_flat_masked", "masked_components", "henderson_two_way"]

_CHUNK = 8  # frames folded at once (float64 working block)
MEMO_MAX_PIXELS = 1 << 21  # accessor results kept between calls up to 1080p (see _memo)


class MaskedStackAccumulator:
    """Streaming sums of a frame stack over the good pixels of a fixed mask.

    ``mask``: boolean (rows, cols), True = excluded pixel. ``add(frame)``,
    ``add_batch(frames)``, ``merge(other)`` as ``StackAccumulator``; accessors give NaN
    at masked pixels.
    """

    masked = True  # dispatch flag for anova.py / flat.py

    # the masked ANOVA, reached through the accumulator: anova.py and flat.py dispatch here
    # without importing this module (which imports them)
    def anova_table(self) -> "MaskedTable":
        return self._memo("table", lambda: masked_table(self))  # (kept: see _memo)

    def decompose_dark(self, table=None) -> dict[str, Estimate]:
        return decompose_dark_masked(self, table)

    @staticmethod
    def decompose_flat(flat_acc, dark_acc, *args) -> dict[str, Estimate]:
        return decompose_flat_masked(flat_acc, dark_acc, *args)

    def __init__(self, shape, mask, batch: int = _CHUNK, pixels=None):
        """``pixels``: a ``StackAccumulator`` over the whole frame that is fed the same
        frames in the same order (a StackSet's full view). With 8/16-bit integer frames
        its exact integer sums give this stack's per-pixel sums, which are then not kept
        twice (two float64 frames less per stack; the same numbers: every sum is an
        exact integer either way)."""
        try:
            shape = tuple(int(s) for s in shape)
        except TypeError:
            raise InputError(f"frame shape must be (rows, cols), got {shape!r}") from None
        if len(shape) != 2 or min(shape) < 1:
            raise InputError(f"frame shape must be (rows, cols) with both >= 1, got {shape}")
        m = np.asarray(mask, bool)
        if m.shape != shape:
            raise InputError(f"mask of shape {m.shape} does not match the frame shape {shape}")
        self.shape = shape
        self.mask = m.copy()
        self.good = ~m
        self.batch = max(1, int(batch))
        self._x0 = None  # shift (first frame, 0 at masked pixels)
        R, C = shape
        self._pixels = pixels
        self._derived = False  # per-pixel sums from ``pixels`` (decided at the first frame)
        self._plan = False  # masked_fold.line_plan of the shift (made at the second frame; None: none applies)
        self._s1 = self._s2 = None  # per-pixel sums of the shifted good pixels (own mode)
        self._r2 = np.zeros(R)  # sum_f (row sum of shifted good pixels)^2
        self._c2 = np.zeros(C)
        self._t2 = 0.0
        self._tot: list[np.ndarray] = []  # per-frame shifted good totals
        self._nf = 0
        self._memos: dict = {}  # accessor -> (frames it was computed at, result)
        self._riding = False  # fed by ``pixels``' folds (see ride)
        self._ride_plan = None  # (good shift's row sums, column sums, masked rows, masked columns)

    @property
    def n_frames(self) -> int:
        self._sync()
        return self._nf

    @property
    def riding(self) -> bool:
        return self._riding

    def ride(self) -> bool:
        """Take this stack's frames from ``pixels``' folds instead of ``add``: its 8/16-bit
        blocks' row and column sums (exact int64), less the masked pixels' values and the
        good shift's sums, are this stack's line sums -- the same integers the one-pass
        ``masked_fold.lines`` forms, without reading the frames again (a 4096x3072 frame:
        ~4 ms). Only before any frame; False when there is no ``pixels`` to ride on. The
        caller then feeds ``pixels`` alone, and calls ``unride`` before it feeds frames of
        another kind (float, wide integers)."""
        p = self._pixels
        if p is None or self._nf or p.n_frames or p._on_fold is not None:
            return False
        p._on_fold = masked_fold.Ride(self)  # (weakly: see masked_fold)
        self._riding = True
        return True

    def unride(self) -> None:
        """Back to ``add`` (the frames ``pixels`` holds unfolded are taken first)."""
        if self._riding:
            self._sync()
            self._pixels._on_fold = None
            self._riding = False

    def _sync(self) -> None:
        if self._riding:
            self._pixels._flush_buffer()  # (its folds call _from_pixels)

    def _from_pixels(self, fr: np.ndarray, fc: np.ndarray, x, xored: list[bool]) -> None:
        """A block folded by ``pixels``: its frames' line sums over the good pixels, shifted,
        one frame at a time as ``add`` folds them (the same float64 sums, bit for bit)."""
        if self._x0 is None:
            self._first(x[0].view(np.int16), True, 1 << 15) if xored[0] else self._first(x[0], True)
            self._ride_plan = masked_fold.line_plan(self._x0, self.good)  # (one pass, numba)
            if self._ride_plan is None:  # the same integers: x0 is integer-valued, 0 at masked pixels
                g = self._x0
                bi, bj = np.nonzero(self.mask)
                self._ride_plan = (g.sum(axis=1, dtype=np.float64).astype(np.int64),
                                   g.sum(axis=0, dtype=np.float64).astype(np.int64), bi, bj)
        xr, xc, bi, bj = self._ride_plan
        R, C = self.shape
        for k in range(len(fr)):
            v = x[k][bi, bj]
            v = (v ^ np.uint16(0x8000) if xored[k] else v).astype(np.float64)  # (exact: |v| < 2**16)
            r = fr[k] - xr - np.bincount(bi, weights=v, minlength=R).astype(np.int64)
            c = fc[k] - xc - np.bincount(bj, weights=v, minlength=C).astype(np.int64)
            self._fold_lines(r[None].astype(np.float64), c[None].astype(np.float64), 1)

    def __del__(self) -> None:  # its shift to the next stack (ares.analysis.kernels.recycle)
        recycle.give(self.__dict__, "_x0")

    @property
    def n_good(self) -> int:
        return int(self.good.sum())

    # ------------------------------------------------------------------ feeding
    def add(self, frame, copy: bool = True) -> None:
        a = np.asarray(frame)
        if a.ndim != 2:
            raise InputError(f"frame {self._nf} must be 2-D (rows, cols), got shape {a.shape}")
        self.add_batch(a[None])

    def add_batch(self, frames) -> None:
        self.unride()  # (fed directly from here on)
        if not isinstance(frames, np.ndarray):
            for f in frames:
                self.add(f)
            return
        a = np.asarray(frames)
        if a.ndim == 2:
            a = a[None]
        if a.ndim != 3 or a.shape[1:] != self.shape:
            raise InputError(f"frame {self._nf} has shape {tuple(a.shape[-2:])}, "
                             f"but this stack's frames are {self.shape}")
        if a.dtype.kind not in "uifb":
            raise InputError(f"frames of type {a.dtype} are not numeric image data")
        for i in range(0, len(a), self.batch):
            self._fold(a[i : i + self.batch])

    def _fold(self, x: np.ndarray) -> None:
        if self._x0 is None and x.dtype.kind in "ui" and x.dtype.itemsize <= 2:
            self._first(x[0], True)  # (the shift straight from the integers: no float64 copy of the block)
        if self._x0 is not None:
            # one pass (integer frames); only the row/column sums when the pixels' come from elsewhere
            if self._derived:
                if self._plan is False:
                    self._plan = masked_fold.line_plan(self._x0, self.good)
                sums = masked_fold.lines(x, self._plan)
            else:
                sums = None
            if sums is None:
                sums = masked_fold.fold(x, self._x0, self.good, None if self._derived else self._s1,
                                        None if self._derived else self._s2)
            if sums is not None:
                self._fold_lines(*sums, len(x))
                return
        d = x.astype(np.float64)
        if x.dtype.kind == "f" and not np.isfinite(d[:, self.good]).all():
            raise InputError(f"frames {self._nf}..{self._nf + len(x) - 1} contain NaN/inf")
        if self._x0 is None:
            self._first(d[0], x.dtype.kind in "uib" and x.dtype.itemsize <= 2)
        d -= self._x0
        d[:, self.mask] = 0.0  # masked pixels contribute nothing
        if not self._derived:
            self._s1 += d.sum(axis=0)
            self._s2 += np.einsum("fij,fij->ij", d, d)
        self._fold_lines(d.sum(axis=2), d.sum(axis=1), len(x))

    def _first(self, frame: np.ndarray, small: bool, off: int = 0) -> None:
        """The stack's shift from its first frame (+ ``off``; 0 at masked pixels) and where its
        per-pixel sums come from. The shift of 8/16-bit integer frames is exact in float32: half
        the memory; their sums can come from the full-frame stack (``pixels``)."""
        self._x0 = masked_fold.shift(frame, self.mask, small, off)
        p = self._pixels
        self._derived = bool(small and p is not None and tuple(p.shape) == self.shape and not p._float)
        if not self._derived:
            self._s1, self._s2 = np.zeros(self.shape), np.zeros(self.shape)

    def _memo(self, key, fn):
        """``fn()``, kept until the stack changes (frames added or merged) for frames up to
        MEMO_MAX_PIXELS: a stage's analysis asks for the sums, the mean map and the forms
        several times each (17 sums a stage, each a few passes over the frame; the
        commit of a make-run stage 16 % less CPU). Four frames of float64 at most (66 MB
        at 1080p); larger frames recompute, memory first. Kept arrays are made read-only,
        so no caller can change them by mistake."""
        if self.mask.size > MEMO_MAX_PIXELS:
            return fn()
        hit = self._memos.get(key)
        if hit is not None and hit[0] == self._nf:
            return hit[1]
        val = fn()
        for a in val if isinstance(val, tuple) else (val,):
            if isinstance(a, np.ndarray):
                a.flags.writeable = False
        self._memos[key] = (self._nf, val)
        return val

    def _sums(self, second: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """(sum over frames of x - x0, of (x - x0)^2) per pixel, 0 at masked pixels, float64
        (read-only when kept by ``_memo``)."""
        if not self._derived:
            return self._s1, self._s2
        if self.mask.size <= MEMO_MAX_PIXELS:
            return self._memo("sums", self._derive_sums)
        return self._derive_sums(second)

    def _derive_sums(self, second: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """From ``pixels`` (derived mode): S1 - n x0 and S2 + x0 (n x0 - 2 S1) in int64 --
        exact integers, so equal to the sums this stack would have kept. Fresh arrays."""
        p = self._pixels
        if p.n_frames != self._nf:
            raise InputError(f"the full-frame stack has {p.n_frames} frames, its masked view {self._nf}")
        p._ready()
        n = self._nf
        x0 = self._x0.astype(np.int64)
        s1 = x0 * n
        s2 = None
        if second:
            t = s1 - p._s1
            t -= p._s1
            t *= x0
            t += p._s2
            s2 = t.astype(np.float64)
            del t
            s2[self.mask] = 0.0
        np.subtract(p._s1, s1, out=s1)
        s1 = s1.astype(np.float64)
        s1[self.mask] = 0.0
        return s1, s2

    def _materialize(self) -> None:
        """Keep this stack's own per-pixel sums from now on (before a merge)."""
        self.unride()
        if self._derived:
            self._s1, self._s2 = self._derive_sums()  # (fresh: this stack's own from now on)
            self._derived, self._pixels = False, None

    def _fold_lines(self, fr: np.ndarray, fc: np.ndarray, n: int) -> None:
        """The row/column/frame-total forms of a folded block's row and column sums."""
        self._r2 += np.einsum("fr,fr->r", fr, fr)
        self._c2 += np.einsum("fc,fc->c", fc, fc)
        t = fr.sum(axis=1)
        self._t2 += float(t @ t)
        self._tot.append(t)
        self._nf += n

    def merge(self, other: "MaskedStackAccumulator") -> "MaskedStackAccumulator":
        """Append the frames of ``other`` (same shape and mask); in place, returns self."""
        if not isinstance(other, MaskedStackAccumulator):
            raise InputError(f"can only merge another MaskedStackAccumulator, not {type(other).__name__}")
        if other.shape != self.shape or not np.array_equal(other.mask, self.mask):
            raise InputError("cannot merge masked stacks of different frame shape or mask")
        self._sync()
        other._sync()
        if other._nf == 0:
            return self
        if self._nf == 0:
            self._x0 = other._x0.copy()
            self._s1, self._s2 = np.zeros(self.shape), np.zeros(self.shape)
        self._materialize()
        n = other._nf
        dl = other._x0.astype(np.float64) - self._x0  # other's shift relative to ours (0 at masked pixels)
        s1o, s2o = other._sums()
        dr, dc, dt = dl.sum(axis=1), dl.sum(axis=0), float(dl.sum())
        self._s2 += s2o + 2 * dl * s1o + n * dl * dl
        self._r2 += other._r2 + 2 * dr * s1o.sum(axis=1) + n * dr * dr
        self._c2 += other._c2 + 2 * dc * s1o.sum(axis=0) + n * dc * dc
        self._t2 += other._t2 + 2 * dt * float(s1o.sum()) + n * dt * dt
        self._s1 += s1o + n * dl
        self._tot += [t + dt for t in other._tot]
        self._nf += n
        return self

    # ------------------------------------------------------------------ accessors
    def _need(self):
        self._sync()
        if self._nf == 0:
            raise InputError("no frames were accumulated")

    def mean_map(self) -> np.ndarray:
        """Time-averaged frame (NaN at masked pixels)."""
        self._need()

        def f():
            s1 = self._sums(False)[0]
            fresh = self._derived and s1.flags.writeable  # derived and not kept: a frame of float64 saved
            m = np.divide(s1, self._nf, out=s1 if fresh else None)
            m += self._x0
            m[self.mask] = np.nan
            return m

        return self._memo("mean", f)

    def pixel_ss(self) -> np.ndarray:
        self._need()

        def f():
            s1, s2 = self._sums()
            return np.where(self.good, np.maximum(s2 - s1 * s1 / self._nf, 0.0), np.nan)

        return self._memo("pixel_ss", f)

    def temporal_var_map(self, ddof: int = 1) -> np.ndarray:
        self._need()
        if self._nf <= ddof:
            return np.full(self.shape, np.nan)
        return self.pixel_ss() / (self._nf - ddof)

    def frame_means(self) -> np.ndarray:
        """(F,) mean of the good pixels of each frame."""
        self._need()
        return (np.concatenate(self._tot) + float(self._x0.sum(dtype=np.float64))) / max(self.n_good, 1)

    def mean(self) -> float:
        self._need()
        return self._memo("mean_value", lambda: float(
            (self._x0.sum(dtype=np.float64) + self._sums(False)[0].sum() / self._nf) / max(self.n_good, 1)))

    def temporal_forms(self) -> dict:
        """The four temporal quadratic forms (summed over frame contrasts) and counts."""
        self._need()
        return dict(self._memo("forms", self._temporal_forms))

    def _temporal_forms(self) -> dict:
        F = self._nf
        g = self.good
        nr, nc = g.sum(axis=1), g.sum(axis=0)
        s1, s2 = self._sums()
        t0 = float(np.where(g, s2 - s1 * s1 / F, 0.0).sum())
        qr = self._r2 - s1.sum(axis=1) ** 2 / F
        qc = self._c2 - s1.sum(axis=0) ** 2 / F
        st = float(s1.sum())
        qt = self._t2 - st * st / F
        tr = float((qr[nr > 0] / nr[nr > 0]).sum())
        tc = float((qc[nc > 0] / nc[nc > 0]).sum())
        N = int(g.sum())
        return {"T0": t0, "TR": tr, "TC": tc, "Tm": qt / N if N else math.nan}

    def nbytes(self) -> int:
        arrays = [self._s1, self._s2, self._r2, self._c2, self._x0, self.mask, self.good] + self._tot
        return int(sum(a.nbytes for a in arrays if isinstance(a, np.ndarray)))

    def __repr__(self) -> str:
        return f"MaskedStackAccumulator(shape={self.shape}, n_frames={self._nf}, masked={int(self.mask.sum())})"


# ---------------------------------------------------------------------- convenience
def masked_components(dark, mask, flat=None, **flat_kw) -> dict[str, Estimate]:
    """Dark (and, with ``flat``, gain) components of recorded (F, R, C) stacks with ``mask``.

    ``mask``: boolean (R, C), True = excluded, or anything with ``.defective()`` (a
    ``DefectResult``). ``flat_kw``: ``gain``, ``illumination``, ``surface_order``.
    """
    if hasattr(mask, "defective"):
        mask = mask.defective()
    dark = np.asarray(dark)
    dacc = MaskedStackAccumulator(dark.shape[1:], mask)
    dacc.add_batch(dark)
    out = dict(dacc.decompose_dark())
    if flat is not None:
        flat = np.asarray(flat)
        facc = MaskedStackAccumulator(flat.shape[1:], mask)
        facc.add_batch(flat)
        out.update(MaskedStackAccumulator.decompose_flat(facc, dacc, **flat_kw))
    return out
