"""The exact 8/16-bit kernel of ``StackAccumulator`` (``ares.analysis.noise.accumulate``): a
block of small-integer frames folded into the per-pixel sums, the row/column sums and
the sums of squares with every partial sum in float32 below 2**24 (exact in any order)
and the squares rebuilt exactly from a float32 estimate and the same sum modulo 2**16.

A mixin: the accumulator's state (``_s1``, ``_s2``, ``_f1``/``_fk``/``_fl``, the working
buffers ``_kp``) is its own; this module only holds the algorithm, apart from the
feeding and the statistics read back.
"""

from __future__ import annotations

import numpy as np

from ares.analysis.kernels import int_fold

_BLOCK_BYTES = 2 << 20  # float32 working block (batch x rows x cols); tuned on 1920x1080
_MAX_RUN = 256  # longest run of 8/16-bit values summed in float32 (256 * 65535 < 2**24)
_ACC_FRAMES = 256  # frames after which the float32 per-pixel totals move to int64
_SQ_FRAMES = 16  # frames per exactly rebuilt group of sums of squares of |y| <= 2**15


class SmallIntFolds:
    """``_fold_small_int`` (with its buffers, ``_plan``) and ``_move_float_totals``."""

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
        # zeroed, not np.empty: no BLAS call ever meets uninitialized memory (the stress test
        # once saw "invalid value encountered in matmul" here on finite integer input)
        p = self._kp = {
            "nb": nb, "n": n, "k": k, "m": m, "segs": segs, "dtype": dtype,
            "t": np.zeros((nb, n, c), np.float32),  # the block as float32 (exact)
            "xb": np.zeros((nb, n, c), dtype),  # gathered block (frames given as a list)
            "A": np.zeros((g, n * c), np.float32),  # float32 sums of squares (approximate)
            "L": np.zeros((g, n * c), np.uint16),  # the same sums modulo 2**16 (exact)
            "Lf": np.zeros((g, n * c), np.float32),
            "o1": np.zeros(n * c, np.float32),
            "ofc": np.zeros((nb, c), np.float32),
            "fc32": np.zeros((nb, c), np.float32),
            "rowp": np.zeros((nb, r, m), np.float32),
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
        self._counted = False  # (set when the fused kernel counted the clips: see StackAccumulator._fold)
        if not self._nfloat:  # the fused kernel (numba) where it is available: exact, one pass
            top, cnt = (int_fold.NO_TOP, None) if self._top is None else (self._top, self._clips)
            if listed:
                blk = np.empty((b, r, c), dtype)
                for i, frame in enumerate(x):
                    if u16 and stored[i]:
                        np.bitwise_xor(frame, 0x8000, out=blk[i])  # the store holds x ^ 0x8000
                    else:
                        np.copyto(blk[i], frame)
                got = int_fold.fold(blk, 0, self._s1, self._s2, top, cnt)
            elif u16 and centred:
                got = int_fold.fold(x.view(np.int16), 1 << 15, self._s1, self._s2, top, cnt)
            else:
                got = int_fold.fold(x, 0, self._s1, self._s2, top, cnt)
            if got is not None:
                self._counted = True
                return got
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
