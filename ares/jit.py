"""numba kernels compiled on first use, one switch for all of them.

``compiled(fn)`` returns ``fn`` jitted (``nogil``: the kernels run beside other threads;
``cache``: compiled once per machine into ``__pycache__``) or None when numba is not
installed or ``ARES_NO_NUMBA=1``; callers keep a numpy path for None. numba is imported
here only when a kernel is first needed, so importing ARES stays light.

``avoided()``: a short command (``ares emva``) whose kernels would save less than numba's
import and first load cost (~0.5 s, ~100 MB resident) runs the numpy paths inside this
block, and numba is not loaded for them (honoured by the kernels that command uses:
``analysis/lowpass.py``, ``analysis/pair_kernel.py``); each agrees with its numpy path
exactly or within float64 rounding (tested). Outside the block nothing changes, so a
process that calls the command in-line (tests, a batch worker) keeps its kernels.
"""

from __future__ import annotations

import contextlib
import os

_avoiding = 0


@contextlib.contextmanager
def avoided():
    global _avoiding
    _avoiding += 1
    try:
        yield
    finally:
        _avoiding -= 1


def avoiding() -> bool:
    return _avoiding > 0


def compiled(fn, inline: bool = False):
    """``inline``: a helper of another kernel, inlined into it (numba IR level), so that
    constant arguments specialise its code at each call."""
    if os.environ.get("ARES_NO_NUMBA"):
        return None
    try:
        from numba import njit
    except ImportError:
        return None
    if inline:
        return njit(inline="always")(fn)
    return njit(cache=True, nogil=True)(fn)
