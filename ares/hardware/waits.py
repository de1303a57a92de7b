"""Bounded, interruptible waits: every wait on an instrument ends by its timeout or by a
stop/abort request within ``SLICE_S`` (Ctrl-C is honoured within a second anywhere)."""

from __future__ import annotations

import time
from typing import Callable

SLICE_S = 0.1


class Interrupted(Exception):
    """A wait cut short because the run was asked to stop or abort."""


def wait(seconds: float, cancel: Callable[[], bool] | None = None, *, sleep=time.sleep,
         clock=time.monotonic) -> None:
    """Sleep ``seconds`` in slices of at most ``SLICE_S``; raise ``Interrupted`` as soon as
    ``cancel()`` is true."""
    end = clock() + max(0.0, float(seconds))
    while True:
        if cancel is not None and cancel():
            raise Interrupted
        left = end - clock()
        if left <= 0:
            return
        sleep(min(SLICE_S, left))
