"""Large arrays handed from a stack that is gone to the next one: new memory's page faults
once per run instead of once per stack.

A 4096x3072 stack's int64 sums (2 x 100 MB), its batch store (48 MB) and its masked view's
shift (50 MB) were new memory for every stack, and the kernel zeroes new pages as they are
first touched: 0.2-0.6 s of system time a stack on this project's VM, 12-35 ms a frame of a
16-frame stack (``benchmarks/live_pipeline.md``). Here an accumulator that is collected, or a
batch store that is compacted, hands its arrays to a pool, and the next stack of the same
shape takes them (zeroed again where it needs zeros: a pass over resident memory).

An array goes to the pool only when nothing else references it (its reference count: no
view, no other name), so a recycled array is never shared. The pool is off (holds nothing)
until ``keep(nbytes)`` sets how much it may hold; the runner turns it on for frames above 4
Mpx and empties it before each stage's analysis, so it never adds to the run's peak
memory: it holds only what the stacks being grabbed would otherwise have had anew.
"""

from __future__ import annotations

import sys
import threading

import numpy as np

MIN_BYTES = 8 << 20  # smaller arrays come from the heap without page faults (ares.malloc)
_lock = threading.Lock()
_free: list[np.ndarray] = []
_cap = [0]  # bytes the pool may hold (0: off)
_EXACT_REFCOUNT = sys.implementation.name == "cpython" and sys.version_info < (3, 14)


def keep(nbytes: int) -> None:
    """Let the pool hold up to ``nbytes`` (0: off, and emptied)."""
    with _lock:
        _cap[0] = max(0, int(nbytes))
        if not _cap[0]:
            _free.clear()


def clear() -> None:
    """Give the pooled arrays back (to the allocator, and the large ones to the system)."""
    with _lock:
        _free.clear()


def held() -> int:
    """Bytes the pool holds now."""
    with _lock:
        return sum(a.nbytes for a in _free)


def _take(shape, dtype) -> np.ndarray | None:
    dtype = np.dtype(dtype)
    shape = tuple(int(s) for s in shape)
    with _lock:
        for i, a in enumerate(_free):
            if a.shape == shape and a.dtype == dtype:
                return _free.pop(i)
    return None


def empty(shape, dtype) -> np.ndarray:
    """A C-ordered array of ``shape`` and ``dtype`` with any contents: a pooled one when the
    pool holds one, else ``np.empty``."""
    a = _take(shape, dtype)
    return np.empty(shape, dtype) if a is None else a


def zeros(shape, dtype) -> np.ndarray:
    """As ``np.zeros``; a pooled array is zeroed in place (its pages are resident)."""
    a = _take(shape, dtype)
    if a is None:
        return np.zeros(shape, dtype)
    a.fill(0)
    return a


def give(owner: dict, *names: str) -> None:
    """Move the arrays ``owner[name]`` (an object's ``__dict__``) to the pool, where nothing
    else references them and the pool has room; the names are removed from ``owner`` (the
    object is being collected, or drops them)."""
    for name in names:
        a = owner.pop(name, None)
        if (_cap[0] and _EXACT_REFCOUNT and type(a) is np.ndarray and a.base is None and a.nbytes >= MIN_BYTES
                and a.flags.c_contiguous and a.flags.writeable and sys.getrefcount(a) == 2):
            with _lock:
                if sum(b.nbytes for b in _free) + a.nbytes <= _cap[0]:
                    _free.append(a)
        del a
