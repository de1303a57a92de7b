"""How busy the machine was while a benchmark measured: ``os.getloadavg`` at the start and
end of a timed window, and the CPU that OTHER processes used during it (Linux: ``/proc/stat``
minus this process and its descendants, e.g. Dask workers), so a figure taken on a busy
machine is labelled as such in its table."""

from __future__ import annotations

import os
import time
from pathlib import Path

TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
QUIET = 0.25  # cores of other work below which a measurement is labelled "quiet"


def _busy_ticks() -> int | None:
    try:
        f = Path("/proc/stat").read_text().splitlines()[0].split()[1:]
    except OSError:
        return None
    user, nice, system, _idle, _iowait, irq, softirq, steal = (int(x) for x in f[:8])
    return user + nice + system + irq + softirq + steal


def _tree_ticks(root: int) -> int:
    """CPU ticks (user + system) of ``root`` and its living descendants, with the children
    they have reaped."""
    parent, ticks = {}, {}
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            s = (p / "stat").read_text()
        except OSError:
            continue
        rest = s[s.rindex(")") + 2:].split()
        # utime + stime, and cutime + cstime: the children it has reaped (a benchmark's finished
        # child processes are its own work, not others')
        parent[int(p.name)], ticks[int(p.name)] = int(rest[1]), sum(int(x) for x in rest[11:15])
    mine, todo = set(), [root]
    while todo:
        q = todo.pop()
        mine.add(q)
        todo += [c for c, pp in parent.items() if pp == q and c not in mine]
    return sum(ticks.get(q, 0) for q in mine)


class Window:
    """``with Window() as w: ...`` then ``w.cell()``: the table cell describing the load."""

    def __enter__(self) -> "Window":
        self.load0 = os.getloadavg()[0]
        self.t0, self.busy0, self.own0 = time.perf_counter(), _busy_ticks(), _tree_ticks(os.getpid())
        return self

    def __exit__(self, *exc) -> None:
        self.el = time.perf_counter() - self.t0
        busy1, own1 = _busy_ticks(), _tree_ticks(os.getpid())
        self.load1 = os.getloadavg()[0]
        self.others = None if self.busy0 is None or busy1 is None else \
            max(0.0, ((busy1 - self.busy0) - (own1 - self.own0)) / TICK / self.el)

    @property
    def quiet(self) -> bool | None:
        return None if self.others is None else self.others < QUIET

    def cell(self) -> str:
        cores = os.cpu_count() or 1
        load = f"load {self.load0:.1f} -> {self.load1:.1f}"
        if self.others is None:
            return f"{load} on {cores} cores (others' CPU not available off Linux)"
        label = "quiet" if self.quiet else "BUSY"
        return f"{label}: other processes used {self.others:.2f} of {cores} cores; {load}"
