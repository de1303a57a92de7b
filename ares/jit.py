"""numba kernels compiled on first use, one switch for all of them.

``compiled(fn)`` returns ``fn`` jitted (``nogil``: the kernels run beside other threads;
``cache``: compiled once per machine into ``__pycache__``) or None when numba is not
installed or ``ARES_NO_NUMBA=1``; callers keep a numpy path for None. numba is imported
here only when a kernel is first needed, so importing ARES stays light.
"""

from __future__ import annotations

import os


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
