"""What a ``StackAccumulator`` (``ares.analysis.noise.accumulate``) gives back once frames are in:
the mean and temporal-variance maps, the frame means and profiles, the ANOVA's exact sums --
computed on first use from the accumulated sums and cached until the next frame -- and the
exact integer sums they are built from."""

from __future__ import annotations

import numpy as np

from ares.errors import InputError


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


class StackReads:
    """The read side of ``StackAccumulator`` (a mixin: the sums it reads are the accumulator's)."""

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
