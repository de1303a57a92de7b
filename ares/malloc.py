"""glibc's allocator settings for ARES's processes (``mallopt``; other C libraries are left
alone, and ``ARES_MALLOC=default`` keeps glibc's own settings).

Small frames (``tune``, by the ``ares`` command at start-up): freed blocks up to 64 MB stay
in the heap and free heap memory goes back to the system only above 256 MB, instead of
mapping and unmapping every large numpy temporary: a VGA float64 image is 2.4 MB, above
glibc's dynamic threshold in threads, and each new one cost its page faults again --
``ares emva`` spent 1 s of its 4 CPU-s in the kernel for them, 0.2 s with this. The price:
up to 256 MB of freed heap stay resident for reuse (+20 MB for ``ares emva``, +60 MB for
``make run``).

Every thread allocates from one arena (``M_ARENA_MAX`` 1): glibc gives each thread its own,
and the blocks a worker thread freed were kept for that thread alone -- ``ares emva``'s
image threads left 25 MB the main thread's analysis could not reuse (peak 88 -> 62 MB).
ARES's threads allocate a few large blocks per frame, so the one arena's lock costs nothing
measurable.

Large frames (``for_frames``, by the runner, only in a process the command tuned): a
4096x3072 scan's temporaries are 24-96 MB each, and kept in the heap they cost more memory
than their page faults cost time (``benchmarks/bench_big_memory.py``: +150 MB resident).
Blocks from 8 MB up are mapped and returned when freed; the heap is trimmed above 32 MB.
"""

from __future__ import annotations

import os
import sys

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD, M_ARENA_MAX = -1, -3, -8
LARGE_FRAME_PIXELS = 1 << 22  # frames above this take the large-frame settings (as the runner's pipelining)
_state: list[str] = []  # "small" / "large" once tuned


def _mallopt():
    if os.environ.get("ARES_MALLOC") == "default" or not sys.platform.startswith("linux"):
        return None
    import ctypes

    try:
        return ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc
        return None


def tune(large: bool = False) -> None:
    """Set the small-frame (default) or large-frame settings."""
    mallopt = _mallopt()
    if mallopt is None:
        return
    mmap, trim = ((8 << 20), (32 << 20)) if large else ((64 << 20), (256 << 20))
    mallopt(M_MMAP_THRESHOLD, mmap)
    mallopt(M_TRIM_THRESHOLD, trim)
    mallopt(M_ARENA_MAX, 1)
    _state[:] = ["large" if large else "small"]


def for_frames(pixels: int) -> None:
    """The settings for frames of ``pixels`` pixels, in a process ``tune`` was called in
    (a library user's process keeps its own)."""
    if _state and (pixels > LARGE_FRAME_PIXELS) != (_state[0] == "large"):
        tune(pixels > LARGE_FRAME_PIXELS)


def release() -> None:
    """Give the heap's free pages back to the system now (``malloc_trim``), in a process
    ``tune`` was called in: between a phase whose freed blocks the next cannot use whole
    (threads' temporaries, then the main thread's) and that next phase, so that the peak
    is the larger phase's, not their sum (``ares emva``: 65-67 -> 63-65 MiB)."""
    if not _state or _mallopt() is None:
        return
    import ctypes

    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError):
        pass
