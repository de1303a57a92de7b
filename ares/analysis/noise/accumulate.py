"""One-pass, mergeable frame-stack accumulator (the input of every noise analysis).

``StackAccumulator(shape)`` keeps, for a stack of F frames of R x C pixels:

* per-pixel sum and sum of squares (R x C each);
* the frame sums (F numbers) and, for the ANOVA, exact running sums of squares of the
  per-(frame,row) and per-(frame,column) sums taken relative to the first frame's
  (so the ANOVA needs no per-frame arrays and memory does not grow with F);
* optionally (``keep_profiles=True``) the per-(frame,row) and per-(frame,column) sums
  themselves (F x R and F x C) for row/column time series. Off by default so that
  memory stays independent of the frame count; the ANOVA never needs them.

Every quantity of the three-way ANOVA (frames x rows x columns, ``anova.py``), the mean
map, the per-pixel temporal variance map, the profiles and frame means follow exactly.

Numerics (SCIENCE.md "Numerics"): integer frames are accumulated *exactly* -- in int64
per pixel and in Python integers for the scalar sums of squares -- a naive float32
sum of squares of 16-bit data gives negative variances. The fast path for 8/16-bit
frames buffers ``batch`` frames and walks the buffer in cache-sized blocks of rows. Inside
a block every linear sum (row, column and frame sums) is a float32 BLAS call on runs
short enough that all partial sums stay below 2**24 (exact in any order); per-pixel
totals are kept in float32 for at most 256 frames and then moved to int64. The sums of
squares of 16-bit data (up to 2**35 for a group of 8 frames) are rebuilt exactly from a
float32 estimate (error < 2**15, proven in ``small_int_fold``) and the same sum modulo
2**16 computed in uint16 arithmetic; no data-dependent assumption is made (full-scale
16-bit data, signed data and any frame count are exact). Float frames are
accumulated in float64 on data shifted by the first frame (per pixel), which keeps the
sums of squares well conditioned. NaN/inf and shape changes are refused with an
``InputError`` naming the frame.
"""

from __future__ import annotations

import numpy as np

from ares.errors import InputError

from ares.analysis.kernels import int_fold
from ares.analysis.kernels import recycle
from ares.analysis.kernels.small_int_fold import SmallIntFolds
from ares.analysis.noise.stack_reads import StackReads, _idot, _isumsq

# The largest magnitude a frame value may have: a 40-bit ADC's full scale. Its square and
# sums of a million frames of it stay far inside float64; a value beyond is a unit slip or
# a corrupt export, refused with one sentence (ptc_table bounds its tables by it too).
MAX_DN = 2.0**40

__all__ = ["StackAccumulator"]

def _as_frames(frames) -> np.ndarray:
    a = np.asarray(frames)
    if a.dtype.kind == "b":
        return a.astype(np.uint8)
    if a.dtype.kind not in "uif":
        raise InputError(f"frames of type {a.dtype} are not numeric image data")
    return a


def _immutable(a: np.ndarray) -> bool:
    """True when nothing can change the frame's memory (a read-only view of ``bytes``)."""
    b = a
    while isinstance(b, np.ndarray):
        if b.flags.writeable:
            return False
        b = b.base
    return isinstance(b, bytes)


class StackAccumulator(SmallIntFolds, StackReads):
    """Streaming sums of a frame stack; see the module docstring.

    ``add(frame)`` / ``add_batch(frames)`` feed frames, ``merge(other)`` appends the
    frames of another accumulator of the same frame shape, ``n_frames`` counts frames.
    Accessors return float64 arrays and raise ``InputError`` on an empty stack.
    """

    def __init__(self, shape, batch: int = 16, keep_profiles: bool = False):
        try:
            shape = tuple(int(s) for s in shape)
        except TypeError:
            raise InputError(f"frame shape must be (rows, cols), got {shape!r}") from None
        if len(shape) != 2 or min(shape) < 1:
            raise InputError(f"frame shape must be (rows, cols) with both >= 1, got {shape}")
        if not 1 <= batch <= 64:
            raise InputError(f"batch must be 1..64 frames, got {batch}")
        self.shape = shape
        self.batch = int(batch)
        self.keep_profiles = bool(keep_profiles)
        self._float = False  # False: exact integer sums; True: float64 sums of x - x0
        self._x0 = None  # float mode: per-pixel shift (the first float frame)
        self._s1 = recycle.zeros(shape, np.int64)  # (a collected stack's, where one is pooled)
        self._s2 = recycle.zeros(shape, np.int64)
        self._nf = 0  # frames folded into the sums
        # scalar ANOVA sums relative to the first frame's row/col sums (a, b)
        self._a = self._b = None
        self._qfr = 0  # sum_fr (FR - a_r)^2
        self._qfc = 0  # sum_fc (FC - b_c)^2
        self._tot: list[np.ndarray] = []  # chunks of per-frame totals (representation space)
        self._fr: list[np.ndarray] = []  # chunks of per-(frame,row) sums (keep_profiles)
        self._fc: list[np.ndarray] = []
        # fast path state
        self._buf = None  # up to `batch` small-integer frames waiting to be folded
        self._store = None  # (batch, R, C) storage of the copied frames
        self._buf_dtype = None
        self._nbuf = 0
        self._kp = None  # working buffers of the 8/16-bit kernel (see _plan)
        self._f1 = self._fk = self._fl = None  # exact float32 partial totals (see _fold_small_int)
        self._nfloat = 0
        self._foff = 0  # offset of the data summed into the float32 totals
        self._cache: dict = {}
        self._top = None  # count_clips: the top code counted (None: not counted)
        self._clips = np.zeros(2, np.int64)  # (values >= _top, values == 0) of the frames folded
        self._counted = False  # the last small-integer fold counted the clips in its pass
        # called with each folded 8/16-bit block: (row sums, column sums (int64, exact), the
        # block, which of its frames hold x ^ 0x8000); a masked view's line sums (see
        # MaskedStackAccumulator.ride), made without another pass over the frames
        self._on_fold = None

    def count_clips(self, top: int) -> None:
        """Count, from now on, the values at or above ``top`` and those equal to 0 of every
        frame added (``clips``): in the fused kernel's one read of each pixel where it runs,
        else by ``int_fold.extremes`` on the folded block (the same counts)."""
        self._top = int(top)

    def clips(self) -> tuple[int, int]:
        """(values >= the ``count_clips`` top, values == 0) over the frames added since."""
        self._flush_buffer()
        return int(self._clips[0]), int(self._clips[1])

    # ------------------------------------------------------------------ feeding
    @property
    def n_frames(self) -> int:
        return self._nf + self._nbuf

    @property
    def exact(self) -> bool:
        """True while the sums are exact integers (integer input only)."""
        return not self._float

    def _check(self, a: np.ndarray, first_index: int) -> None:
        if a.shape[-2:] != self.shape:
            raise InputError(
                f"frame {first_index} has shape {tuple(a.shape[-2:])}, but this stack's frames are {self.shape}"
            )
        if a.dtype.kind == "f":
            ok = np.abs(a) <= MAX_DN  # (False for NaN)
            if not ok.all():
                bad = first_index
                if a.ndim == 3:
                    bad += int(np.argmin(ok.reshape(len(a), -1).all(axis=1)))
                x = a[bad - first_index] if a.ndim == 3 else a
                if not np.isfinite(x).all():
                    raise InputError(f"frame {bad} contains NaN/inf")
                raise InputError(f"frame {bad} contains {float(np.abs(x).max()):g} DN, beyond a sensor's values "
                                 "(|x| <= 2^40 DN)")

    def add(self, frame, copy: bool = True) -> None:
        """Add one 2-D frame (integer or finite float).

        8/16-bit frames are buffered (``batch`` of them) and folded together, which is
        several times faster than folding each frame. ``copy=False`` keeps a reference
        instead of copying the frame into the buffer: only for producers that never
        reuse a frame's memory (the frame must not change until ``batch`` more frames
        were added or an accessor was called). Frames that nothing can change (read-only
        views of ``bytes``, as decoded images are) are never copied.
        """
        a = _as_frames(frame)
        if a.ndim != 2:
            raise InputError(f"frame {self.n_frames} must be 2-D (rows, cols), got shape {a.shape}")
        self._check(a, self.n_frames)
        self._cache.clear()
        if a.dtype.kind in "ui" and a.dtype.itemsize <= 2 and not self._float:
            if self._buf is None or self._buf_dtype != a.dtype:
                self._flush_buffer()
                self._buf = [None] * self.batch
                self._store = recycle.empty((self.batch,) + self.shape, a.dtype)
                self._buf_dtype = a.dtype
            if copy and not _immutable(a):
                if a.dtype == np.uint16:  # stored centred: x - 2**15 as int16 bits (see _fold_small_int)
                    np.bitwise_xor(a, 0x8000, out=self._store[self._nbuf])
                else:
                    self._store[self._nbuf] = a
                self._buf[self._nbuf] = self._store[self._nbuf]
            else:
                self._buf[self._nbuf] = a
            self._nbuf += 1
            if self._nbuf == self.batch:
                self._flush_buffer()
        else:
            self._flush_buffer()
            self._fold(a[None])

    def add_batch(self, frames) -> None:
        """Add a 3-D array (frames, rows, cols) or an iterable of 2-D frames."""
        if not isinstance(frames, np.ndarray):
            for f in frames:
                self.add(f)
            return
        a = _as_frames(frames)
        if a.ndim == 2:
            self.add(a)
            return
        if a.ndim != 3:
            raise InputError(f"a batch of frames must be 3-D (frames, rows, cols), got shape {a.shape}")
        if len(a) == 0:
            return
        self._check(a, self.n_frames)
        self._cache.clear()
        self._flush_buffer()
        step = 32 if (a.dtype.kind in "ui" and a.dtype.itemsize <= 2) else 16
        for i in range(0, len(a), step):
            self._fold(a[i : i + step])

    def _flush_buffer(self) -> None:
        if self._nbuf:
            n = self._nbuf
            self._nbuf = 0
            frames = self._buf[:n]
            self._buf[:n] = [None] * n
            if all(f.base is self._store for f in frames):
                self._fold(self._store[:n], centred=True)  # one conversion call per block
            else:
                self._fold(frames)

    def _flush(self) -> None:
        self._flush_buffer()
        self._move_float_totals()

    # ------------------------------------------------------------------ kernels
    def _fold(self, x, centred: bool = False) -> None:
        """Fold a 3-D block (or a list of same-type 2-D frames) into the sums.

        ``centred``: a uint16 block of the batch buffer, which holds x ^ 0x8000.
        """
        if isinstance(x, list) and (self._float or x[0].dtype.itemsize > 2):
            x = np.stack(x)
        if not isinstance(x, list) and x.dtype.kind == "f" and not self._float:
            self._to_float()
        self._counted = False
        if self._float:
            fr, fc = self._fold_float(x)
        elif isinstance(x, list) or x.dtype.itemsize <= 2:
            fr, fc = self._fold_small_int(x, centred)
            if self._on_fold is not None:
                self._on_fold(fr, fc, x, self._xored(x, centred))
        else:
            fr, fc = self._fold_wide_int(x)
        if self._top is not None and not self._counted:
            self._count_clips(x, centred)
        self._fold_profiles(fr, fc)
        self._nf += len(x)

    def _count_clips(self, x, centred: bool) -> None:
        """The clip counts of a block the fused kernel did not count (its values as added:
        uint16 frames of the batch store hold x ^ 0x8000)."""
        for f, xored in zip(x, self._xored(x, centred)):
            hi, lo = int_fold.extremes(f ^ np.uint16(0x8000) if xored else f, self._top)
            self._clips += (hi, lo)

    def _xored(self, x, centred: bool) -> list[bool]:
        """Per frame of a block being folded: whether it holds x ^ 0x8000 (a uint16 frame
        of the batch store) rather than the frame as added."""
        if isinstance(x, list):
            return [f.dtype == np.uint16 and f.base is self._store for f in x]
        return [x.dtype == np.uint16 and centred] * len(x)

    def _fold_profiles(self, fr: np.ndarray, fc: np.ndarray) -> None:
        """Update the scalar ANOVA sums with the (b, R) row sums and (b, C) column sums."""
        if self._a is None:
            self._a = fr[0].copy()
            self._b = fc[0].copy()
        dr = fr - self._a
        dc = fc - self._b
        if self._float:
            self._qfr += float(np.einsum("ij,ij->", dr, dr))
            self._qfc += float(np.einsum("ij,ij->", dc, dc))
        else:
            self._qfr += _isumsq(dr)
            self._qfc += _isumsq(dc)
        self._tot.append(fr.sum(axis=1))
        if self.keep_profiles:
            self._fr.append(fr)
            self._fc.append(fc)

    def _fold_wide_int(self, x: np.ndarray):
        x = x.astype(np.int64)
        lim = 1 << 24
        if x.size and (x.max() >= lim or x.min() <= -lim):
            raise InputError(
                f"frames {self._nf}..{self._nf + len(x) - 1}: integer values beyond 2**24 cannot be "
                "accumulated exactly; pass them as float"
            )
        self._s1 += x.sum(axis=0)
        self._s2 += np.einsum("fij,fij->ij", x, x)
        return x.sum(axis=2), x.sum(axis=1)

    def _fold_float(self, x: np.ndarray):
        if self._x0 is None:
            self._x0 = np.asarray(x[0], np.float64).copy()
        d = np.asarray(x, np.float64) - self._x0
        self._s1 += d.sum(axis=0)
        self._s2 += np.einsum("fij,fij->ij", d, d)
        return d.sum(axis=2), d.sum(axis=1)

    def _to_float(self) -> None:
        """Switch from exact integer sums to float64 sums (shift 0)."""
        self._flush()
        self._float = True
        # an empty stack takes its shift from its first frame (see _fold_float)
        self._x0 = np.zeros(self.shape, np.float64) if self._nf else None
        self._s1 = self._s1.astype(np.float64)
        self._s2 = self._s2.astype(np.float64)
        self._qfr = float(self._qfr)
        self._qfc = float(self._qfc)
        if self._a is not None:
            self._a = self._a.astype(np.float64)
            self._b = self._b.astype(np.float64)
        self._tot = [t.astype(np.float64) for t in self._tot]
        self._fr = [a.astype(np.float64) for a in self._fr]
        self._fc = [a.astype(np.float64) for a in self._fc]

    def compact(self) -> None:
        """Fold the buffered frames and free the working buffers (batch store, kernel
        scratch: up to ~8x a frame); a finished stack keeps only its sums. They are made
        again if frames are added later."""
        self._flush()
        self._buf = self._buf_dtype = self._kp = self._f1 = self._fk = self._fl = None
        recycle.give(self.__dict__, "_store")  # (to the next stack, where the pool is on)
        self._store, self._nbuf, self._nfloat = None, 0, 0

    def __del__(self) -> None:  # its large arrays to the next stack (ares.analysis.kernels.recycle)
        recycle.give(self.__dict__, "_s1", "_s2", "_store")

    def __getstate__(self) -> dict:
        """Pickled (e.g. sent back by a Dask worker) as its sums only: buffered frames are
        folded first and the working buffers (batch store, kernel scratch, ~8x a frame)
        are left behind -- they are re-created when frames are added again."""
        self._flush()
        state = dict(self.__dict__)
        state.update(_buf=None, _store=None, _buf_dtype=None, _nbuf=0, _kp=None, _f1=None, _fk=None, _fl=None,
                     _nfloat=0, _cache={}, _on_fold=None)
        return state

    # ------------------------------------------------------------------ merging
    def merge(self, other: "StackAccumulator") -> "StackAccumulator":
        """Append the frames of ``other`` after those of ``self`` (in place; returns self).

        Exact for integer data: the result equals one pass over both stacks.
        """
        if not isinstance(other, StackAccumulator):
            raise InputError(f"can only merge another StackAccumulator, not {type(other).__name__}")
        if other.shape != self.shape:
            raise InputError(f"cannot merge stacks of frame shape {other.shape} into {self.shape}")
        if other is self:
            raise InputError("cannot merge an accumulator with itself")
        self._flush()
        other._flush()
        self._cache.clear()
        self._clips += other._clips  # (both count the same top, or neither is read)
        if other._nf == 0:
            return self
        if other._float and not self._float:
            self._to_float()
        if self._nf == 0:
            self._copy_from(other)
            return self
        nb = other._nf
        if self._float:
            # other's representation relative to ours: d_b + delta per pixel
            x0b = other._x0 if other._float else np.zeros(self.shape)
            delta = x0b - self._x0
            s1b = np.asarray(other._s1, np.float64)
            s2b = np.asarray(other._s2, np.float64)
            self._s1 = self._s1 + s1b + nb * delta
            self._s2 = self._s2 + s2b + 2.0 * delta * s1b + nb * delta * delta
            sr, sc = delta.sum(axis=1), delta.sum(axis=0)
            ab = np.asarray(other._a, np.float64) + sr - self._a  # row-sum shift
            bb = np.asarray(other._b, np.float64) + sc - self._b
            ur = s1b.sum(axis=1) - nb * np.asarray(other._a, np.float64)  # sum_f (FR_b - a_b)
            vc = s1b.sum(axis=0) - nb * np.asarray(other._b, np.float64)
            self._qfr += float(other._qfr) + 2.0 * float(ab @ ur) + nb * float(ab @ ab)
            self._qfc += float(other._qfc) + 2.0 * float(bb @ vc) + nb * float(bb @ bb)
            tshift = float(sr.sum())
            self._tot += [np.asarray(t, np.float64) + tshift for t in other._tot]
            if self.keep_profiles and other.keep_profiles:
                self._fr += [np.asarray(a, np.float64) + sr for a in other._fr]
                self._fc += [np.asarray(a, np.float64) + sc for a in other._fc]
            else:
                self._drop_profiles()
        else:
            self._s1 += other._s1
            self._s2 += other._s2
            ab = other._a - self._a
            bb = other._b - self._b
            ur = other._s1.sum(axis=1) - nb * other._a
            vc = other._s1.sum(axis=0) - nb * other._b
            self._qfr += other._qfr + 2 * _idot(ab, ur) + nb * _isumsq(ab)
            self._qfc += other._qfc + 2 * _idot(bb, vc) + nb * _isumsq(bb)
            self._tot += [t.copy() for t in other._tot]
            if self.keep_profiles and other.keep_profiles:
                self._fr += [a.copy() for a in other._fr]
                self._fc += [a.copy() for a in other._fc]
            else:
                self._drop_profiles()
        self._nf += nb
        return self

    def _drop_profiles(self) -> None:
        self.keep_profiles = False
        self._fr, self._fc = [], []

    def _copy_from(self, other: "StackAccumulator") -> None:
        f = np.float64 if self._float else None
        cv = (lambda a: np.asarray(a, f).copy()) if f else (lambda a: a.copy())
        if self._float:
            self._x0 = other._x0.copy() if other._float else np.zeros(self.shape)
        self._s1, self._s2 = cv(other._s1), cv(other._s2)
        self._a, self._b = cv(other._a), cv(other._b)
        self._qfr = float(other._qfr) if self._float else other._qfr
        self._qfc = float(other._qfc) if self._float else other._qfc
        self._tot = [cv(t) for t in other._tot]
        if self.keep_profiles and other.keep_profiles:
            self._fr = [cv(a) for a in other._fr]
            self._fc = [cv(a) for a in other._fc]
        else:
            self._drop_profiles()
        self._nf = other._nf

    # ------------------------------------------------------------------ accessors
    def __repr__(self) -> str:
        return f"StackAccumulator(shape={self.shape}, n_frames={self.n_frames})"
