"""The GUI's "Auto Repeat": one scan run again and again until a run is not ``done``."""

from __future__ import annotations

from typing import Callable

from ares.scan.runner import Runner
from ares.scan.stage_loop import RunOutcome


def auto_repeat(make_runner: Callable[[int], Runner], count: int = 0,
                should_continue: Callable[[], bool] = lambda: True) -> list[RunOutcome]:
    """Run ``make_runner(i)`` for i = 0, 1, ... (``count`` times, 0 = until a run is
    stopped/aborted or ``should_continue()`` says no): the GUI's "Auto Repeat"."""
    out = []
    i = 0
    while (count == 0 or i < count) and should_continue():
        o = make_runner(i).run()
        out.append(o)
        if o.status != "done":
            break
        i += 1
    return out
