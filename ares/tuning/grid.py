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
    size: int | tuple[int, int]  # sensor rows = cols, or (rows, cols): the scan's own sensor
    fidelity: str  # simulator shot noise: "auto", "exact", "gaussian"

    def label(self) -> str:
        size = f"{self.size[1]}x{self.size[0]}" if isinstance(self.size, tuple) else f"{self.size}px"
        return f"{size} {self.frames}f {self.levels}{self.spacing[:3]} {self.fidelity}"

    @property
    def rows_cols(self) -> tuple[int, int]:
        return self.size if isinstance(self.size, tuple) else (self.size, self.size)


# --quick runs on a 64x64 cut of the sensor (a minute); the full grid on the scan's own
# sensor (``own_size``), so that its recommendation is for the user's sensor
QUICK = dict(frames=(2, 4, 8), levels=(9, 25), spacing=("log",), size=(64,), fidelity=("auto", "exact"))
FULL = dict(frames=(2, 4, 8, 16), levels=(9, 17, 25), spacing=("log", "linear"), size=None,
            fidelity=("auto", "exact"))


def own_size(scan) -> tuple[int, int]:
    """The scan's sensor as (rows, cols)."""
    return scan.system.sensor.rows, scan.system.sensor.cols


def settings(grid: dict) -> list[Setting]:
    keys = ("frames", "levels", "spacing", "size", "fidelity")
    return [Setting(*combo) for combo in itertools.product(*(grid[k] for k in keys))]


def sweep_axis(scan):
    """(stage index, axis index) of the swept level axis (light or exposure) the knobs resize.
    A 2-D sweep (the level axis beside another axis of more than one point, e.g. gain x light)
    is refused: its stages are not one photon-transfer curve, so every setting would report
    the mixture's "errors" against a truth that is not the scan's."""
    for i, st in enumerate(scan.stages):
        for j, ax in enumerate(st.axes):
            if ax.key in ("light", "exposure") and ax.kind in ("log", "linear"):
                other = [a for a in st.axes if a is not ax and len(a.grid()) > 1]
                if other:
                    raise InputError(
                        f"scan '{scan.name}': stage '{st.name}' sweeps {other[0].key} x {ax.key} (a 2-D sweep); "
                        f"ares bench varies one light or exposure sweep: give it a scan with a 1-D sweep "
                        "(e.g. scans/photon_transfer.xml)")
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
    rows, cols = s.rows_cols
    params = dict(sy.simulator.params, rows=rows, cols=cols, shot_noise=s.fidelity)
    sy = dataclasses.replace(sy, sensor=dataclasses.replace(sy.sensor, rows=rows, cols=cols, optical_black=()),
                             simulator=dataclasses.replace(sy.simulator, params=params))
    regions = tuple(r for r in scan.regions if r.x + r.width <= cols and r.y + r.height <= rows)
    return dataclasses.replace(scan, system=sy, stages=tuple(stages), regions=regions, limits=(), precision=None)
