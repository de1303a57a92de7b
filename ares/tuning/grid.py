"""The knobs ``ares bench`` turns, and the scan each setting makes.

A ``Setting`` changes a simulator scan in the ways that trade time for accuracy: frames
per stage, the number and spacing of the sweep's levels, the sensor size (the region the
statistics come from), and the simulator's shot-noise fidelity. The estimator choice is
not a knob of the scan: every run reports each estimator of a figure (the gain from the
whole photon-transfer fit and from the single mid level of the decomposition) and the
table compares them.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass

from ares.errors import InputError


@dataclass(frozen=True)
class Setting:
    frames: int
    levels: int
    spacing: str  # "log" or "linear"
    size: int  # sensor rows = cols
    fidelity: str  # simulator shot noise: "auto", "exact", "gaussian"

    def label(self) -> str:
        return f"{self.size}px {self.frames}f {self.levels}{self.spacing[:3]} {self.fidelity}"


QUICK = dict(frames=(2, 4, 8), levels=(9, 25), spacing=("log",), size=(64,), fidelity=("auto", "exact"))
FULL = dict(frames=(2, 4, 8, 16), levels=(9, 17, 25), spacing=("log", "linear"), size=(64, 128, 256),
            fidelity=("auto", "exact"))


def settings(grid: dict) -> list[Setting]:
    keys = ("frames", "levels", "spacing", "size", "fidelity")
    return [Setting(*combo) for combo in itertools.product(*(grid[k] for k in keys))]


def sweep_axis(scan):
    """(stage index, axis index) of the swept level axis (light or exposure) the knobs resize."""
    for i, st in enumerate(scan.stages):
        for j, ax in enumerate(st.axes):
            if ax.key in ("light", "exposure") and ax.kind in ("log", "linear"):
                return i, j
    raise InputError(f"scan '{scan.name}' has no light or exposure sweep with <log> or <linear> points "
                     "for ares bench to vary")


def scan_for(scan, s: Setting):
    """The scan at setting ``s``: its sweep resampled, the sensor cut to ``s.size``
    (regions that do not fit dropped), the simulator's fidelity set, no limits."""
    sy = scan.system
    if sy.simulator is None:
        raise InputError(f"system '{sy.name}' is not a simulator: ares bench varies simulator settings "
                         "(use --pilot on a real bench)")
    i, j = sweep_axis(scan)
    st = scan.stages[i]
    ax = dataclasses.replace(st.axes[j], kind=s.spacing, points=s.levels)
    if s.spacing == "log" and (ax.start <= 0 or ax.stop <= 0):
        raise InputError(f"stage '{st.name}': a log spacing needs positive start and stop")
    stages = list(scan.stages)
    stages[i] = dataclasses.replace(st, axes=st.axes[:j] + (ax,) + st.axes[j + 1:])
    params = dict(sy.simulator.params, rows=s.size, cols=s.size, shot_noise=s.fidelity)
    sy = dataclasses.replace(sy, sensor=dataclasses.replace(sy.sensor, rows=s.size, cols=s.size, optical_black=()),
                             simulator=dataclasses.replace(sy.simulator, params=params))
    regions = tuple(r for r in scan.regions if r.x + r.width <= s.size and r.y + r.height <= s.size)
    return dataclasses.replace(scan, system=sy, stages=tuple(stages), regions=regions, limits=(), precision=None)
