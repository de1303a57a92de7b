"""The simulator's general charge path (photo and dark charge drawn apart, image lag,
full-well clipping) as one fused pass over the frame (numba), bit-identical to the numpy
steps in ``SimSensor._frame``/``_add_charge``.

The numpy path makes about a dozen full-frame float32 temporaries per frame (three
normal deviates, the lag split, the clip, the gain maps); here each pixel is computed
once, in the same float32 operations in the same order (no fused multiply-add: numba's
default keeps IEEE semantics), from the same random integers drawn by the same
generator calls in the same order -- so every code matches the numpy path (tested).
Without numba (``ARES_NO_NUMBA=1`` or not installed) the numpy path runs.

numba is imported and the kernels loaded (from numba's cache, or compiled once) on first
use or by ``warm()`` -- the runner calls it before a simulated scan's first frame, so the
0.7 s is never counted as a stage's work and importing the simulator stays light.
"""

from __future__ import annotations

import contextlib
import os

import numpy as np

_F32 = np.float32
_compiled = _compiled_lookup = None
_loaded = False


def _load() -> None:
    global _compiled, _compiled_lookup, _loaded
    if _loaded:
        return
    _loaded = True
    if os.environ.get("ARES_NO_NUMBA"):
        return
    try:
        from numba import njit
    except ImportError:  # the numpy path
        return
    _compiled = njit(cache=True, nogil=True)(_kernel)
    _compiled_lookup = njit(cache=True, nogil=True)(_lookup_kernel)


def available() -> bool:
    _load()
    return _compiled is not None


@contextlib.contextmanager
def enabled(on: bool):
    """Run a block with the fused kernels on or off (tests and benchmarks compare both)."""
    global _compiled, _compiled_lookup
    _load()
    keep = _compiled, _compiled_lookup
    if not on:
        _compiled = _compiled_lookup = None
    try:
        yield
    finally:
        _compiled, _compiled_lookup = keep


def warm() -> None:
    """Load (or compile) both kernels now, with the argument types a frame uses."""
    if not available():
        return
    f, u = np.zeros(2, _F32), np.zeros(2, np.uint16)
    _compiled(np.zeros(4, _F32), u, u, u, f, f, f, f, True, _F32(0.5), f, True, np.zeros(2, _F32), _F32(1e4),
              _F32(1.0), f, f, np.zeros(2, _F32))
    _compiled_lookup(f, np.zeros(4, np.int32), np.full(4, np.inf), 1, 1, np.zeros(2, np.uint16))


def _kernel(T, i1, i2, i3, sigma, offs, q, dark_e, has_dark, lag, left, has_left, lag_out, fw, G, pgr, cgrg, x):
    """One pass over the raveled frame; ``q`` / ``dark_e`` hold one value (uniform) or one
    per pixel."""
    n = x.size
    q_map, d_map = q.size > 1, dark_e.size > 1
    q0 = q[0]
    sq0 = np.sqrt(q0)
    d0 = dark_e[0]
    sd0 = np.sqrt(d0)
    for i in range(n):
        v = T[i1[i]] * sigma[i]
        v = v + offs[i]
        if q_map:
            qq = q[i]
            p = T[i2[i]] * np.sqrt(qq)
        else:
            qq = q0
            p = T[i2[i]] * sq0
        p = p + qq
        if lag > 0:
            carried = lag * p
            lag_out[i] = carried
            p = p - carried
            if has_left:
                p = p + left[i]
        lim = fw
        if has_dark:
            if d_map:
                de = dark_e[i]
                d = T[i3[i]] * np.sqrt(de)
            else:
                de = d0
                d = T[i3[i]] * sd0
            d = d + de
            if fw < d:
                d = fw
            v = v + G * d
            lim = fw - d
        pix = pgr[i] * p
        if lim < pix:
            pix = lim
        v = v + cgrg[i] * pix
        x[i] = v


def applies(sc, plan, flutter: float) -> bool:
    """The case the kernel covers: Gaussian shot noise everywhere (no exact-Poisson pixel,
    the fast normal table), photo-charge present, no flutter this frame."""
    _load()
    return (_compiled is not None and plan["gauss_fast"] and plan["sigma"] is not None and plan["has_q"]
            and plan["mask_q"] is False and plan["mask_d"] is False and flutter == 1.0)


def charge_frame(rng, sc, plan, shape, left, table):
    """(x in DN before the line terms and the ADC, the photo-charge carried to the next
    frame or None): what ``_frame`` + ``_add_charge`` compute on this path, with the
    generator called exactly as they call it (read noise, photo shot, dark shot)."""
    i1 = rng.integers(0, 1 << 16, size=shape, dtype=np.uint16)
    i2 = rng.integers(0, 1 << 16, size=shape, dtype=np.uint16)
    has_dark = sc.dark_e is not None
    i3 = rng.integers(0, 1 << 16, size=shape, dtype=np.uint16) if has_dark else i1

    def flat(a):  # one value, or a contiguous (writable: one numba signature) per-pixel map
        a = np.asarray(a, _F32)
        if a.size == 1:
            return a.reshape(1).copy()
        return np.ascontiguousarray(a).reshape(-1) if a.shape == shape else np.broadcast_to(a, shape).ravel()

    q = flat(sc.q)
    dark = flat(sc.dark_e) if has_dark else q
    lag = _F32(sc.lag)
    size = shape[0] * shape[1]
    lag_out = np.empty(size if lag > 0 else 1, _F32)
    x = np.empty(shape, _F32)
    maps = [np.ascontiguousarray(plan[k]).ravel() for k in ("sigma", "offs", "pgr", "cgrg")]
    _compiled(table, i1.ravel(), i2.ravel(), i3.ravel(), maps[0], maps[1], q, dark, has_dark, lag,
              left.ravel() if left is not None else lag_out, left is not None, lag_out, _F32(plan["fw"]),
              _F32(sc.G), maps[2], maps[3], x.ravel())
    lag_out = lag_out.reshape(shape) if lag > 0 else None
    return x, lag_out


def _lookup_kernel(x, base, tpad, per_cell, max_code, out):
    """``ADC._lookup`` in one pass over the raveled frame: the code is the count of levels
    at or below the cell floor(x) plus the levels inside the cell that are <= x (compared
    in float64, as searchsorted does)."""
    hi = max_code + 1
    for i in range(x.size):
        v = x[i]
        j = min(max(np.floor(v), -1.0), hi)  # branch-free: the comparisons below are data-dependent
        b = base[int(j) + 1]
        code = b
        vd = np.float64(v)
        for m in range(per_cell):
            code += np.int32(vd >= tpad[b + m])
        out[i] = code


def adc_lookup(x: np.ndarray, base: np.ndarray, tpad: np.ndarray, per_cell: int, max_code: int,
               out: np.ndarray) -> bool:
    """Codes of a 2-D float32 frame into ``out`` (uint16) by the ADC's threshold table;
    False when the fused kernel does not apply (the numpy lookup runs instead)."""
    _load()
    if (_compiled_lookup is None or out is None or out.dtype != np.uint16 or x.dtype != _F32
            or not x.flags.c_contiguous or not out.flags.c_contiguous):
        return False
    _compiled_lookup(x.ravel(), base, tpad, per_cell, max_code, out.ravel())
    return True
