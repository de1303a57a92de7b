"""One-pass, mergeable frame-stack accumulator (the input of every noise analysis).

``StackAccumulator(shape)`` keeps, for a stack of F frames of R x C pixels:

* per-pixel sum and sum of squares (R x C each),
* per-(frame, row) sums (F x R) and per-(frame, column) sums (F x C),

so memory is O(R*C + F*(R+C)) whatever the frame count, and every quantity of the
three-way ANOVA (frames x rows x columns, see ``anova.py``), the mean map, the per-pixel
temporal variance map, the row/column profiles and the frame means follow exactly.

Numerics (SCIENCE.md "Numerics"): integer frames (8/16-bit, or wider up to 2**24) are
accumulated *exactly* in int64 -- float32 sum-of-squares on 16-bit data gives negative
variances. The fast path buffers ``batch`` frames and walks the buffer in cache-sized
blocks of rows; inside a block the partial sums over <= 64 frames are formed in float64,
which is exact for 16-bit data (64 * 65535**2 < 2**53), then moved to the int64 totals.
Float frames are accumulated in float64 on data shifted by the first frame (per pixel),
which keeps the sum of squares well conditioned. NaN/inf and shape changes are refused
with an ``InputError`` naming the frame.
"""

from __future__ import annotations

import numpy as np

from ares.errors import InputError

__all__ = ["StackAccumulator"]

_BLOCK_BYTES = 384 * 1024  # float64 working block, sized to stay in a 512 KiB-1 MiB L2


def _as_frames(frames) -> np.ndarray:
    a = np.asarray(frames)
    if a.dtype.kind not in "uif":
        if a.dtype.kind == "b":
            return a.astype(np.uint8)
        raise InputError(f"frames of type {a.dtype} are not numeric image data")
    return a


class StackAccumulator:
    """Streaming sums of a frame stack; see the module docstring.

    ``add(frame)`` / ``add_batch(frames)`` feed frames, ``merge(other)`` combines two
    accumulators of the same frame shape (frames of ``other`` follow those of ``self``),
    ``n_frames`` counts frames. Accessors return float64 arrays.
    """

    def __init__(self, shape, batch: int = 16):
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
        r, c = shape
        self._float = False  # False: exact int64 sums; True: float64 sums of x - x0
        self._x0 = None  # float mode: per-pixel shift (the first float frame)
        self._s1 = np.zeros(shape, np.int64)
        self._s2 = np.zeros(shape, np.int64)
        self._fr: list[np.ndarray] = []  # chunks of per-(frame,row) sums
        self._fc: list[np.ndarray] = []  # chunks of per-(frame,col) sums
        self._nf = 0  # frames folded into the sums
        self._buf = None  # (batch, R, C) buffer of small-integer frames
        self._nbuf = 0
        self._tmp = None  # float64 working block
        self._cache: dict = {}

    # ------------------------------------------------------------------ feeding
    @property
    def n_frames(self) -> int:
        return self._nf + self._nbuf

    def _check(self, a: np.ndarray, first_index: int) -> None:
        if a.shape[-2:] != self.shape:
            raise InputError(
                f"frame {first_index} has shape {tuple(a.shape[-2:])}, but this stack's frames are {self.shape}"
            )
        if a.dtype.kind == "f":
            ok = np.isfinite(a)
            if not ok.all():
                bad = first_index + (int(np.argmin(ok.reshape(len(a), -1).all(axis=1))) if a.ndim == 3 else 0)
                raise InputError(f"frame {bad} contains NaN/inf")

    def add(self, frame) -> None:
        """Add one 2-D frame (integer or finite float)."""
        a = _as_frames(frame)
        if a.ndim != 2:
            raise InputError(f"frame {self.n_frames} must be 2-D (rows, cols), got shape {a.shape}")
        self._check(a, self.n_frames)
        self._cache.clear()
        if a.dtype.kind in "ui" and a.dtype.itemsize <= 2 and not self._float:
            if self._buf is None or self._buf.dtype != a.dtype:
                self._flush()
                self._buf = np.empty((self.batch,) + self.shape, a.dtype)
            self._buf[self._nbuf] = a
            self._nbuf += 1
            if self._nbuf == self.batch:
                self._flush()
        else:
            self._flush()
            self._fold(a[None])

    def add_batch(self, frames) -> None:
        """Add a 3-D array (frames, rows, cols) or an iterable of frames."""
        a = _as_frames(frames) if isinstance(frames, np.ndarray) else None
        if a is None:
            for f in frames:
                self.add(f)
            return
        if a.ndim == 2:
            self.add(a)
            return
        if a.ndim != 3:
            raise InputError(f"a batch of frames must be 3-D (frames, rows, cols), got shape {a.shape}")
        if len(a) == 0:
            return
        self._check(a, self.n_frames)
        self._cache.clear()
        self._flush()
        step = 64 if (a.dtype.kind in "ui" and a.dtype.itemsize <= 2) else 16
        for i in range(0, len(a), step):
            self._fold(a[i : i + step])

    def _flush(self) -> None:
        if self._nbuf:
            n = self._nbuf
            self._nbuf = 0
            self._fold(self._buf[:n])

    # ------------------------------------------------------------------ kernels
    def _fold(self, x: np.ndarray) -> None:
        """Fold a 3-D block of frames into the sums."""
        if x.dtype.kind == "f" and not self._float:
            self._to_float()
        if self._float:
            self._fold_float(x)
        elif x.dtype.itemsize <= 2:
            self._fold_small_int(x)
        else:
            self._fold_wide_int(x)
        self._nf += len(x)

    def _fold_small_int(self, x: np.ndarray) -> None:
        # exact: |x| < 2**16, so b <= 64 squares sum below 2**53 in float64
        b, r, c = x.shape
        rb = max(1, min(r, _BLOCK_BYTES // (8 * b * c)))
        if self._tmp is None or self._tmp.shape[0] < b or self._tmp.shape[1] < rb:
            self._tmp = np.empty((max(b, self.batch), rb, c), np.float64)
        fr = np.empty((b, r), np.int64)
        fc = np.zeros((b, c), np.float64)
        s1, s2 = self._s1, self._s2
        for r0 in range(0, r, rb):
            r1 = min(r, r0 + rb)
            t = self._tmp[:b, : r1 - r0]
            np.copyto(t, x[:, r0:r1], casting="unsafe")
            fr[:, r0:r1] = t.sum(axis=2)
            fc += t.sum(axis=1)
            s1[r0:r1] += np.add.reduce(t, axis=0).astype(np.int64)
            np.multiply(t, t, out=t)
            s2[r0:r1] += np.add.reduce(t, axis=0).astype(np.int64)
        self._fr.append(fr)
        self._fc.append(fc.astype(np.int64))

    def _fold_wide_int(self, x: np.ndarray) -> None:
        x = x.astype(np.int64)
        lim = 1 << 24
        if x.size and (x.max() >= lim or x.min() <= -lim):
            raise InputError(
                f"frames {self._nf}..{self._nf + len(x) - 1}: integer values beyond 2**24 cannot be "
                "accumulated exactly; pass them as float"
            )
        self._s1 += x.sum(axis=0)
        self._s2 += np.einsum("fij,fij->ij", x, x)
        self._fr.append(x.sum(axis=2))
        self._fc.append(x.sum(axis=1))

    def _fold_float(self, x: np.ndarray) -> None:
        if self._x0 is None:
            self._x0 = np.asarray(x[0], np.float64).copy()
        d = x.astype(np.float64) - self._x0
        self._s1 += d.sum(axis=0)
        self._s2 += np.einsum("fij,fij->ij", d, d)
        self._fr.append(d.sum(axis=2))
        self._fc.append(d.sum(axis=1))

    def _to_float(self) -> None:
        """Switch from exact integer sums to float64 sums (shift 0)."""
        self._flush()
        self._float = True
        self._x0 = np.zeros(self.shape, np.float64)
        self._s1 = self._s1.astype(np.float64)
        self._s2 = self._s2.astype(np.float64)
        self._fr = [a.astype(np.float64) for a in self._fr]
        self._fc = [a.astype(np.float64) for a in self._fc]

    # ------------------------------------------------------------------ merging
    def merge(self, other: "StackAccumulator") -> "StackAccumulator":
        """Add the frames of ``other`` after those of ``self`` (in place; returns self)."""
        if not isinstance(other, StackAccumulator):
            raise InputError(f"can only merge another StackAccumulator, not {type(other).__name__}")
        if other.shape != self.shape:
            raise InputError(f"cannot merge stacks of frame shape {other.shape} into {self.shape}")
        if other is self:
            raise InputError("cannot merge an accumulator with itself")
        self._flush()
        other._flush()
        self._cache.clear()
        if other._nf == 0:
            return self
        if self._nf == 0 and not self._float and not other._float:
            self._s1 = other._s1.copy()
            self._s2 = other._s2.copy()
        elif not self._float and not other._float:
            self._s1 += other._s1
            self._s2 += other._s2
        else:
            if not self._float:
                self._to_float()
            if self._nf == 0:
                self._x0 = other._x0.copy() if other._float else np.zeros(self.shape)
            x0b = other._x0 if other._float else np.zeros(self.shape)
            delta = x0b - self._x0  # other's data relative to our shift: d_b + delta
            s1b = np.asarray(other._s1, np.float64)
            s2b = np.asarray(other._s2, np.float64)
            nb = other._nf
            self._s1 = self._s1 + s1b + nb * delta
            self._s2 = self._s2 + s2b + 2.0 * delta * s1b + nb * delta * delta
            dr, dc = delta.sum(axis=1), delta.sum(axis=0)
            self._fr += [np.asarray(a, np.float64) + dr for a in other._fr]
            self._fc += [np.asarray(a, np.float64) + dc for a in other._fc]
            self._nf += nb
            return self
        self._fr += [a.copy() for a in other._fr]
        self._fc += [a.copy() for a in other._fc]
        self._nf += other._nf
        return self

    # ------------------------------------------------------------------ accessors
    def _ready(self) -> None:
        self._flush()
        if self._nf == 0:
            raise InputError("no frames were accumulated")

    def _cached(self, key, fn):
        self._ready()
        if key not in self._cache:
            self._cache[key] = fn()
        return self._cache[key]

    @property
    def exact(self) -> bool:
        """True while the sums are exact integers (integer input only)."""
        return not self._float

    def pixel_sum(self) -> np.ndarray:
        """Sum over frames of each pixel (float64, R x C)."""

        def f():
            s = self._s1.astype(np.float64)
            return s + self._nf * self._x0 if self._float else s

        return self._cached("psum", f)

    def mean_map(self) -> np.ndarray:
        """Time-averaged frame (float64, R x C)."""
        return self._cached("mean", lambda: self.pixel_sum() / self._nf)

    def pixel_ss(self) -> np.ndarray:
        """Per-pixel sum over frames of squared deviations from the pixel's mean (>= 0)."""

        def f():
            n = self._nf
            if self._float:
                ss = self._s2 - self._s1 * self._s1 / n
                return np.maximum(ss, 0.0)
            s1, s2 = self._s1, self._s2
            # n*S2 - S1**2 exactly in int64 when it fits, else in extended precision
            if s1.size == 0:
                return np.zeros(self.shape)
            big = max(int(np.abs(s1).max()), 1) ** 2 >= 2**62 or n * int(s2.max()) >= 2**62
            if not big:
                num = n * s2 - s1 * s1
            else:
                num = n * s2.astype(np.longdouble) - s1.astype(np.longdouble) ** 2
                num = np.maximum(num, 0)
            return (num / n).astype(np.float64)

        return self._cached("pss", f)

    def temporal_var_map(self, ddof: int = 1) -> np.ndarray:
        """Per-pixel temporal variance over frames (ddof=1 by default); NaN if F <= ddof."""
        n = self.n_frames
        if n <= ddof:
            self._ready()
            return np.full(self.shape, np.nan)
        return self.pixel_ss() / (n - ddof)

    def frame_row_sums(self) -> np.ndarray:
        """(F, R) per-frame row sums (float64, shift added back)."""

        def f():
            a = np.concatenate(self._fr).astype(np.float64)
            return a + self._x0.sum(axis=1) if self._float else a

        return self._cached("fr", f)

    def frame_col_sums(self) -> np.ndarray:
        """(F, C) per-frame column sums (float64, shift added back)."""

        def f():
            a = np.concatenate(self._fc).astype(np.float64)
            return a + self._x0.sum(axis=0) if self._float else a

        return self._cached("fc", f)

    def frame_row_means(self) -> np.ndarray:
        return self.frame_row_sums() / self.shape[1]

    def frame_col_means(self) -> np.ndarray:
        return self.frame_col_sums() / self.shape[0]

    def frame_means(self) -> np.ndarray:
        """(F,) mean of each frame."""
        return self._cached("fm", lambda: self.frame_row_sums().sum(axis=1) / (self.shape[0] * self.shape[1]))

    def row_profile(self) -> np.ndarray:
        """(R,) mean of each row over frames and columns."""
        return self.mean_map().mean(axis=1)

    def col_profile(self) -> np.ndarray:
        """(C,) mean of each column over frames and rows."""
        return self.mean_map().mean(axis=0)

    def mean(self) -> float:
        return float(self.mean_map().mean())

    def __repr__(self) -> str:
        return f"StackAccumulator(shape={self.shape}, n_frames={self.n_frames})"
