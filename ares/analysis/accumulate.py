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
float32 estimate (error < 2**15, proven in ``_fold_small_int``) and the same sum modulo
2**16 computed in uint16 arithmetic; no data-dependent assumption is made (full-scale
16-bit data, signed data and any frame count are exact). Float frames are
accumulated in float64 on data shifted by the first frame (per pixel), which keeps the
sums of squares well conditioned. NaN/inf and shape changes are refused with an
``InputError`` naming the frame.
"""

from __future__ import annotations

import numpy as np

from ares.errors import InputError

__all__ = ["StackAccumulator"]

_BLOCK_BYTES = 2 << 20  # float32 working block (batch x rows x cols); tuned on 1920x1080
_MAX_RUN = 256  # longest run of 8/16-bit values summed in float32 (256 * 65535 < 2**24)
_ACC_FRAMES = 256  # frames after which the float32 per-pixel totals move to int64
_SQ_FRAMES = 16  # frames per exactly rebuilt group of sums of squares of |y| <= 2**15


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


def _isum(a) -> int:
    """Exact sum of an integer array as a Python int."""
    a = np.asarray(a)
    if a.size == 0:
        return 0
    m = int(np.abs(a).max())
    if m * a.size < 2**62:
        return int(a.sum(dtype=np.int64))
    return int(sum(int(v) for v in a.ravel()))


def _isumsq(a) -> int:
    """Exact sum of squares of an integer array as a Python int."""
    a = np.asarray(a, np.int64)
    if a.size == 0:
        return 0
    m = int(np.abs(a).max())
    if m * m * a.size < 2**62:
        a = a.ravel()
        return int(np.dot(a, a))
    return sum(int(v) * int(v) for v in a.ravel())


def _idot(a, b) -> int:
    return sum(int(x) * int(y) for x, y in zip(np.ravel(a), np.ravel(b)))


class StackAccumulator:
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
        self._s1 = np.zeros(shape, np.int64)
        self._s2 = np.zeros(shape, np.int64)
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
            ok = np.isfinite(a)
            if not ok.all():
                bad = first_index
                if a.ndim == 3:
                    bad += int(np.argmin(ok.reshape(len(a), -1).all(axis=1)))
                raise InputError(f"frame {bad} contains NaN/inf")

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
                self._store = np.empty((self.batch,) + self.shape, a.dtype)
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
        if self._float:
            fr, fc = self._fold_float(x)
        elif isinstance(x, list) or x.dtype.itemsize <= 2:
            fr, fc = self._fold_small_int(x, centred)
        else:
            fr, fc = self._fold_wide_int(x)
        self._fold_profiles(fr, fc)
        self._nf += len(x)

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

    def _plan(self, b: int, dtype) -> dict:
        """Working buffers of the 8/16-bit kernel (sized for up to ``nb`` frames)."""
        p = self._kp
        if p is not None and p["nb"] >= b and p["dtype"] == dtype:
            return p
        r, c = self.shape
        nb = max(b, self.batch, p["nb"] if p is not None else 0)
        n = max(1, min(r, _MAX_RUN, _BLOCK_BYTES // (4 * nb * c)))
        k = max(d for d in range(1, min(c, _MAX_RUN) + 1) if c % d == 0)
        if c // k > 64:  # no usable divisor: row sums over explicit column segments
            k = 0
            segs = [(c0, min(c, c0 + _MAX_RUN)) for c0 in range(0, c, _MAX_RUN)]
        else:
            segs = None
        m = c // k if k else len(segs)
        g = -(-nb // (_SQ_FRAMES // 2))  # groups of squares (8 frames at the least)
        p = self._kp = {
            "nb": nb, "n": n, "k": k, "m": m, "segs": segs, "dtype": dtype,
            "t": np.empty((nb, n, c), np.float32),  # the block as float32 (exact)
            "xb": np.empty((nb, n, c), dtype),  # gathered block (frames given as a list)
            "A": np.empty((g, n * c), np.float32),  # float32 sums of squares (approximate)
            "L": np.empty((g, n * c), np.uint16),  # the same sums modulo 2**16 (exact)
            "Lf": np.empty((g, n * c), np.float32),
            "o1": np.empty(n * c, np.float32),
            "ofc": np.empty((nb, c), np.float32),
            "fc32": np.zeros((nb, c), np.float32),
            "rowp": np.empty((nb, r, m), np.float32),
            "ones_k": np.ones(max(k, _MAX_RUN), np.float32),
            "ones_n": np.ones(n, np.float32),
            "ones_b": np.ones(nb, np.float32),
        }
        return p

    def _fold_small_int(self, x, centred: bool = False):
        """Exact kernel for 8/16-bit integer frames (b <= 64 frames, a block of rows at a time).

        The kernel sums y = x - off: off = 2**15 for uint16 frames that were centred on
        their way into the batch buffer (x ^ 0x8000 read as int16 is x - 2**15: free
        during the copy), else 0. The offsets are added back exactly in int64.

        Float32 represents every integer below 2**24 exactly and sums of such integers are
        exact in any order while every partial sum stays below 2**24. The kernel keeps it so:
        row sums over runs of <= 256 columns, column sums over runs of <= 256 rows, sums
        over <= 64 frames, and float32 per-pixel totals over <= 256 frames (then moved to
        int64): 256 * 65535 < 2**24. Squares (up to 2**32) are not exact in float32; their
        sum S over a group of g frames is rebuilt exactly from two parts: L = S mod 2**16
        (uint16 arithmetic wraps modulo 2**16, and y*y = (y mod 2**16)**2 modulo 2**16) and
        A = the float32 sum of squares. With u = 2**-24, any summation order gives
        |A - S| <= g u S (1 + O(g u)) (Higham, gamma_{g-1}, plus the rounding of each
        square), and fl(A - L) adds at most u S. For |y| <= 2**15 (signed or centred data)
        and g = 16: S <= 2**34, error < 17 * 2**10 < 2**15; for uncentred uint16 and g = 8:
        S < 2**35, error < 9 * 2**11 < 2**15. So K = rint((A - L) / 2**16) is exactly
        (S - L) / 2**16 and S = 2**16 K + L. K and L are summed in float32 (exact: sum K
        <= sum S / 2**16 < 256 * 65535 over 256 frames). For 8-bit frames the float32
        squares and their sums are exact outright.
        """
        b = len(x)
        r, c = self.shape
        listed = isinstance(x, list)
        dtype = x[0].dtype
        u16 = dtype == np.uint16
        if listed:  # gathered per block, uint16 frames centred on the way
            stored = [f.base is self._store for f in x]
            centred = u16
        off = 1 << 15 if (u16 and centred) else 0  # the kernel sums y = x - off
        wide = dtype.itemsize == 2
        # frames per exact group of squares: |y| <= 2**15 allows 16, uncentred uint16 8
        gs = (_SQ_FRAMES if (dtype.kind == "i" or off) else _SQ_FRAMES // 2) if wide else b
        if self._nfloat and (self._nfloat + b > _ACC_FRAMES or self._foff != off):
            self._move_float_totals()
        self._foff = off
        if self._f1 is None:
            self._f1 = np.zeros(r * c, np.float32)
            self._fk = np.zeros(r * c, np.float32)
            self._fl = np.zeros(r * c, np.float32)
        p = self._plan(b, dtype)
        n, k, m, segs = p["n"], p["k"], p["m"], p["segs"]
        tt, xb = p["t"], p["xb"]
        ones_n, ones_b, ones_k = p["ones_n"], p["ones_b"][:b], p["ones_k"]
        o1, ofc, fc32 = p["o1"], p["ofc"][:b], p["fc32"][:b]
        rowp = p["rowp"][:b]
        rowp2 = rowp.reshape(b, r * m)
        fc = np.zeros((b, c), np.float64)
        fc32.fill(0.0)
        run = 0  # rows summed into fc32 since it was last moved to fc
        full = b - b % gs
        spans = [(g0, g1, g1 - g0 if g1 - g0 < gs else gs) for g0, g1 in ((0, full), (full, b)) if g1 > g0]
        f1, fk, fl = self._f1, self._fk, self._fl
        for r0 in range(0, r, n):
            r1 = min(r, r0 + n)
            nn = r1 - r0
            P = nn * c
            if listed:
                src = xb[:b, :nn]
                for i, frame in enumerate(x):
                    if u16 and not stored[i]:
                        np.bitwise_xor(frame[r0:r1], 0x8000, out=src[i])
                    else:
                        np.copyto(src[i], frame[r0:r1])
            else:
                src = x[:, r0:r1]
            t = tt[:b, :nn]
            np.copyto(t, src.view(np.int16) if off else src, casting="unsafe")
            # per-(frame,row) sums, in runs of k <= 256 columns
            if k:
                np.matmul(t.reshape(b, nn * m, k), ones_k[:k], out=rowp2[:, r0 * m : r1 * m])
            else:
                for j, (c0, c1) in enumerate(segs):
                    np.matmul(t[:, :, c0:c1], ones_k[: c1 - c0], out=rowp[:, r0:r1, j])
            # per-(frame,column) sums over this block's <= 256 rows
            if run + nn > _MAX_RUN:
                fc += fc32
                fc32.fill(0.0)
                run = 0
            np.matmul(ones_n[:nn], t, out=ofc)
            fc32 += ofc
            run += nn
            # per-pixel sums over the b frames
            t2 = t.reshape(b, P)
            np.matmul(ones_b, t2, out=o1[:P])
            f1[r0 * c : r1 * c] += o1[:P]
            # per-pixel sums of squares, exact per group of <= 8 frames (see docstring)
            fkb, flb = fk[r0 * c : r1 * c], fl[r0 * c : r1 * c]
            if wide:
                x2 = src.reshape(b, P)
                if dtype.kind == "i":
                    x2 = x2.view(np.uint16)  # y*y modulo 2**16 = (y mod 2**16)**2 mod 2**16
            for g0, g1, sz in spans:
                ng = (g1 - g0) // sz
                A = p["A"][:ng, :P]
                if ng == 1:  # the 2-D form is a faster einsum loop
                    np.einsum("sp,sp->p", t2[g0:g1], t2[g0:g1], out=A[0])
                else:
                    np.einsum("gsp,gsp->gp", t2[g0:g1].reshape(ng, sz, P), t2[g0:g1].reshape(ng, sz, P), out=A)
                if not wide:
                    for i in range(ng):
                        flb += A[i]
                    continue
                L, Lf = p["L"][:ng, :P], p["Lf"][:ng, :P]
                if ng == 1:  # uint16 arithmetic: modulo 2**16
                    np.einsum("sp,sp->p", x2[g0:g1], x2[g0:g1], out=L[0])
                else:
                    xg = x2[g0:g1].reshape(ng, sz, P)
                    np.einsum("gsp,gsp->gp", xg, xg, out=L)
                np.copyto(Lf, L)
                A -= Lf
                A *= 1.0 / 65536
                np.rint(A, out=A)
                for i in range(ng):
                    fkb += A[i]
                    flb += Lf[i]
        fc += fc32
        self._nfloat += b
        fr = rowp.sum(axis=2, dtype=np.float64) if m > 1 else rowp[:, :, 0].astype(np.float64)
        fr, fc = fr.astype(np.int64), fc.astype(np.int64)
        if off:
            fr += off * c
            fc += off * r
        return fr, fc

    def _move_float_totals(self) -> None:
        if self._f1 is not None and self._nfloat:
            r, c = self.shape
            s1, s2 = self._s1.reshape(-1), self._s2.reshape(-1)
            step = 1 << 16
            n, off = self._nfloat, self._foff  # totals of y = x - off over n frames
            for i in range(0, r * c, step):
                j = i + step
                f1 = self._f1[i:j].astype(np.int64)
                s1[i:j] += f1 + n * off
                # sum x^2 = sum y^2 + 2 off sum y + n off^2, sum y^2 = 2**16 K + L
                s2[i:j] += (self._fk[i:j].astype(np.int64) << 16) + self._fl[i:j].astype(np.int64)
                if off:
                    s2[i:j] += 2 * off * f1 + n * off * off
            self._f1.fill(0.0)
            self._fk.fill(0.0)
            self._fl.fill(0.0)
        self._nfloat = 0

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
        self._buf = self._store = self._buf_dtype = self._kp = self._f1 = self._fk = self._fl = None
        self._nbuf = self._nfloat = 0

    def __getstate__(self) -> dict:
        """Pickled (e.g. sent back by a Dask worker) as its sums only: buffered frames are
        folded first and the working buffers (batch store, kernel scratch, ~8x a frame)
        are left behind -- they are re-created when frames are added again."""
        self._flush()
        state = dict(self.__dict__)
        state.update(_buf=None, _store=None, _buf_dtype=None, _nbuf=0, _kp=None, _f1=None, _fk=None, _fl=None,
                     _nfloat=0, _cache={})
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
    def _ready(self) -> None:
        self._flush()
        if self._nf == 0:
            raise InputError("no frames were accumulated")

    def _cached(self, key, fn):
        self._ready()
        if key not in self._cache:
            self._cache[key] = fn()
        return self._cache[key]

    def pixel_sum(self) -> np.ndarray:
        """Sum over frames of each pixel (float64, R x C; not cached: the mean map is)."""
        self._ready()
        s = self._s1.astype(np.float64)
        return s + self._nf * self._x0 if self._float else s

    def mean_map(self) -> np.ndarray:
        """Time-averaged frame (float64, R x C)."""

        def f():
            m = self.pixel_sum()
            m /= self._nf  # in place: one frame of float64 instead of two
            return m

        return self._cached("mean", f)

    def _pss_num(self):
        """n * (per-pixel within SS): exact integers (int64 or longdouble) in int mode. Not
        cached (a frame of int64; the maps made from it are)."""
        self._ready()
        n = self._nf
        if self._float:
            return np.maximum(n * self._s2 - self._s1 * self._s1, 0.0)
        s1, s2 = self._s1, self._s2
        if int(np.abs(s1).max()) ** 2 < 2**62 and n * int(s2.max()) < 2**62:
            num = s1 * s1
            np.subtract(n * s2, num, out=num)
            return num
        return np.maximum(n * s2.astype(np.longdouble) - s1.astype(np.longdouble) ** 2, 0)

    def pixel_ss(self) -> np.ndarray:
        """Per-pixel sum over frames of squared deviations from the pixel's mean (>= 0).
        Not cached (a frame of float64; the ANOVA keeps only its total)."""
        self._ready()
        return (self._pss_num() / self._nf).astype(np.float64, copy=False)

    def temporal_var_map(self, ddof: int = 1) -> np.ndarray:
        """Per-pixel temporal variance over frames (ddof=1 by default); NaN if F <= ddof.

        For integer data this is the exactly rounded value of the exact rational
        (n*S2 - S1**2) / (n*(n-ddof)).
        """
        self._ready()
        n = self._nf
        if n <= ddof:
            return np.full(self.shape, np.nan)
        return (self._pss_num() / (n * (n - ddof))).astype(np.float64, copy=False)

    def frame_sums(self) -> np.ndarray:
        """(F,) sum of each frame."""

        def f():
            t = np.concatenate(self._tot).astype(np.float64)
            return t + float(self._x0.sum()) if self._float else t

        return self._cached("fs", f)

    def frame_means(self) -> np.ndarray:
        """(F,) mean of each frame."""
        return self.frame_sums() / (self.shape[0] * self.shape[1])

    def _profiles(self, which: str) -> np.ndarray:
        if not self.keep_profiles:
            raise InputError("per-frame row/column sums were not kept (keep_profiles=False)")
        chunks = self._fr if which == "r" else self._fc
        a = np.concatenate(chunks).astype(np.float64)
        if self._float:
            a = a + self._x0.sum(axis=1 if which == "r" else 0)
        return a

    def frame_row_means(self) -> np.ndarray:
        """(F, R) mean of each row in each frame (needs keep_profiles)."""
        return self._cached("frm", lambda: self._profiles("r") / self.shape[1])

    def frame_col_means(self) -> np.ndarray:
        """(F, C) mean of each column in each frame (needs keep_profiles)."""
        return self._cached("fcm", lambda: self._profiles("c") / self.shape[0])

    def row_profile(self) -> np.ndarray:
        """(R,) mean of each row over frames and columns."""
        return self.mean_map().mean(axis=1)

    def col_profile(self) -> np.ndarray:
        """(C,) mean of each column over frames and rows."""
        return self.mean_map().mean(axis=0)

    def mean(self) -> float:
        return float(self.mean_map().mean())

    def temporal_sums(self) -> dict:
        """Exact temporal sums of squares for the ANOVA (see anova.py).

        ``ss_f``, ``ss_fr``, ``ss_fc``: SS of the frame main effect and of the
        frame x row, frame x column interactions; ``w``: sum over pixels of the
        within-pixel SS (= SS_F + SS_FR + SS_FC + SS_E).
        """

        def f():
            F = self._nf
            R, C = self.shape
            tot = np.concatenate(self._tot)
            if self._float:
                A = float(self._a.sum())
                t = tot - A
                st, qt = float(t.sum()), float(t @ t)
                u = self._s1.sum(axis=1) - F * self._a
                v = self._s1.sum(axis=0) - F * self._b
                qu, qv = float(u @ u), float(v @ v)
                w = float(self.pixel_ss().sum())
                ss_fr = (F * R * self._qfr - F * qt - R * qu + st * st) / (F * R * C)
                ss_fc = (F * C * self._qfc - F * qt - C * qv + st * st) / (F * R * C)
                ss_f = (F * qt - st * st) / (F * R * C)
            else:
                A = _isum(self._a)
                t = tot - A
                st, qt = _isum(t), _isumsq(t)
                u = self._s1.sum(axis=1) - F * self._a
                v = self._s1.sum(axis=0) - F * self._b
                qu, qv = _isumsq(u), _isumsq(v)
                num_fr = F * R * self._qfr - F * qt - R * qu + st * st
                num_fc = F * C * self._qfc - F * qt - C * qv + st * st
                num_f = F * qt - st * st
                ss_fr, ss_fc, ss_f = (num / (F * R * C) for num in (num_fr, num_fc, num_f))
                w = float(self.pixel_ss().sum())
            return {"ss_f": ss_f, "ss_fr": ss_fr, "ss_fc": ss_fc, "w": w}

        return self._cached("tsums", f)

    def nbytes(self) -> int:
        """Bytes held by the accumulator's arrays (state, buffers, profiles)."""
        arrays = [self._s1, self._s2, self._store, self._f1, self._fk, self._fl, self._x0, self._a, self._b]
        arrays += [v for v in (self._kp or {}).values() if isinstance(v, np.ndarray)]
        arrays += self._tot + self._fr + self._fc
        return int(sum(a.nbytes for a in arrays if isinstance(a, np.ndarray)))

    def __repr__(self) -> str:
        return f"StackAccumulator(shape={self.shape}, n_frames={self.n_frames})"
