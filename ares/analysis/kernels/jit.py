"""numba kernels compiled on first use, one switch for all of them (the warm-up entry is ``ares.jit``).

``compiled(fn)`` returns ``fn`` jitted (``nogil``: the kernels run beside other threads;
``cache``: compiled once per machine into ``__pycache__``) or None when numba is not
installed or ``ARES_NO_NUMBA=1``; callers keep a numpy path for None. numba is imported
here only when a kernel is first needed, so importing ARES stays light.

``avoided()``: a short command (``ares emva`` on a small set: ``emva.uses_kernels``) whose
kernels would save less than numba's import and first load cost (~0.5 - 1 s, ~60 - 100 MB
resident) runs the numpy paths inside this
block, and numba is not loaded for them (honoured by the kernels that command uses:
``analysis/kernels/lowpass.py``, ``analysis/kernels/pair.py``, ``analysis/kernels/int_fold.py``,
``analysis/kernels/highpass.py``); each agrees with its numpy path
exactly or within float64 rounding (tested). Outside the block nothing changes, so a
process that calls the command in-line (tests, a batch worker) keeps its kernels.

First use on a machine: numba compiles each kernel once (~10 s for all of them on this
project's 2-core VM) and caches it. ``make`` does that at install (``python -m ares.jit``,
``warm_all``), so the first ``make run`` does not wait for it (``benchmarks/first_run.md``);
a kernel that still has to be compiled says so once on stderr when stderr is a terminal
(or ``ARES_ANNOUNCE_COMPILE=1``), so a slow first run is not a mystery.
"""

from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path

_avoiding = 0
_announced = False


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
    d = njit(cache=True, nogil=True)(fn)
    if not cached(d):
        _announce(fn.__qualname__)
    return d


def cached(dispatcher) -> bool:
    """Whether numba's cache holds ``dispatcher``'s compiled code (its index file exists);
    True when that cannot be told (no cache, a numba that keeps it elsewhere)."""
    try:
        return os.path.exists(dispatcher._cache._cache_file._index_path)
    except (AttributeError, TypeError):
        return True


# the modules whose kernels ``jit.compiled`` caches (``warm_all`` loads every one), under ares/
_ROOT = Path(os.path.abspath(__file__)).parents[2]  # ares/ (as numba names folders: not resolved)
KERNEL_MODULES = ("sim/fused.py", "analysis/kernels/lowpass.py", "analysis/kernels/int_fold.py", "analysis/kernels/masked_fold.py",
                  "analysis/kernels/pair.py", "analysis/kernels/highpass.py", "analysis/kernels/hmm.py")


def kernels_cached() -> bool:
    """Whether a run will load every kernel from numba's cache rather than compile it in
    the run (a first run: 20-53 MiB more at its peak, ``ares.scan.preflight``), told without
    importing numba (``ares validate`` stays light): each kernel module has an index file
    (``*.nbi``) for this Python, newer than the module, where numba keeps it -- under
    ``NUMBA_CACHE_DIR`` when that is set, else in ``__pycache__`` beside the module (an
    install that cannot write there caches elsewhere: then this says False, and the
    estimate errs high). True when no kernel would be compiled (numba missing or
    ``ARES_NO_NUMBA``)."""
    import importlib.util

    if os.environ.get("ARES_NO_NUMBA") or importlib.util.find_spec("numba") is None:
        return True
    tag = f"py{sys.version_info[0]}{sys.version_info[1]}"
    for rel in KERNEL_MODULES:
        src = _ROOT / rel
        try:
            newest = max(p.stat().st_mtime for p in cache_folder(src).glob(f"{src.stem}.*.{tag}.nbi"))
            if newest < src.stat().st_mtime:
                return False
        except (ValueError, OSError):  # none there, or unreadable
            return False
    return True


def cache_folder(src: Path) -> Path:
    """Where numba caches the kernels of module file ``src`` (its locators, without
    importing numba): ``NUMBA_CACHE_DIR``/<folder name>_<sha1 of the folder> when that is
    set, else ``__pycache__`` beside the module."""
    import hashlib

    custom = os.environ.get("NUMBA_CACHE_DIR")
    if custom:
        return Path(custom) / f"{src.parent.name}_{hashlib.sha1(str(src.parent).encode()).hexdigest()}"
    return src.parent / "__pycache__"


def _announce(name: str) -> None:
    global _announced
    if _announced:
        return
    _announced = True
    if os.environ.get("ARES_ANNOUNCE_COMPILE") == "1" or (sys.stderr is not None and sys.stderr.isatty()):
        sys.stderr.write(f"ares: compiling the numba kernels for this machine ({name} first), once: later runs "
                         "load them from the cache (make does this at install)\n")
        sys.stderr.flush()


