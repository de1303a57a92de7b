"""Expand a scan into its stages (1-D and 2-D sweeps) and estimate its duration.

A :class:`Stage` carries fully resolved settings: the scan's ``<settings>``, then the
stage's ``<set>``s, then its axis values (later ones win), plus ``light = 0`` for a dark
scene. A flat stage with ``dark="matched"`` gets a dark stack at the same settings with
the light off; consecutive stages with the same dark settings share it
(``dark_source = "reuse"``), so a light sweep takes one dark, an exposure sweep one per
exposure. With ``dark="after"`` the matched dark is grabbed right after the flat, never
reused: every stage is then a bright->dark cycle at its own settings, which the lag
analysis reads (a 2-D bias sweep gives a lag map).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

from ares.protocol import Scan

# Order in which settings reach the hardware: slow things first, light last.
_ORDER = {"temperature": 0, "exposure": 2, "analog_gain": 3, "wavelength": 3.5, "light": 4}


def _order(key: str) -> tuple[int, str]:
    return (_ORDER.get(key, 1), key)


@dataclass(frozen=True)
class Stage:
    index: int
    name: str  # e.g. "ptc[3]" or "bias_map[2,1]"; the spec's name for a single stage
    group: str  # the <stage>/<sweep> name
    scene: str  # "dark" or "flat"
    frames: int
    settings: dict = field(hash=False)  # key -> value, in application order
    dark_frames: int = 0  # matched dark frames (0: none)
    dark_source: str = "none"  # "none", "grab" or "reuse" (same dark settings as the previous matched dark)
    coords: tuple[int, ...] = ()
    dark_after: bool = False  # the matched dark is grabbed after the flat (dark="after")

    @property
    def dark_settings(self) -> dict:
        d = dict(self.settings)
        d["light"] = 0.0
        return d

    def frames_to_grab(self) -> int:
        return self.frames + (self.dark_frames if self.dark_source == "grab" else 0)


def _key(settings: dict) -> tuple:
    return tuple(sorted(settings.items()))


def expand(scan: Scan, frames: int | None = None) -> list[Stage]:
    """All stages of ``scan`` in run order; ``frames`` overrides every frame count."""
    out: list[Stage] = []
    last_dark = None
    for spec in scan.stages:
        base = {s.key: s.value for s in scan.settings}
        base.update({s.key: s.value for s in spec.settings})
        grids = [a.grid() for a in spec.axes]
        for coords in itertools.product(*[range(len(g)) for g in grids]) if grids else [()]:
            st = dict(base)
            for a, g, i in zip(spec.axes, grids, coords):
                st[a.key] = float(g[i])
            if spec.scene == "dark":
                st["light"] = 0.0
            st = {k: float(st[k]) for k in sorted(st, key=_order)}
            n = frames or spec.frames or scan.frames
            nd, source = 0, "none"
            if spec.scene == "flat" and spec.dark == "after":
                nd, source = frames or spec.dark_frames or n, "grab"
                last_dark = (_key({**st, "light": 0.0}), nd)
            elif spec.scene == "flat" and spec.dark == "matched":
                nd = frames or spec.dark_frames or n
                dk = (_key({**st, "light": 0.0}), nd)
                source = "reuse" if dk == last_dark else "grab"
                last_dark = dk
            elif spec.scene == "dark":
                last_dark = (_key(st), n)  # a dark stage can serve as the next matched dark
            name = spec.name + (f"[{','.join(str(c) for c in coords)}]" if spec.axes else "")
            out.append(Stage(len(out), name, spec.name, spec.scene, n, st, nd, source, tuple(coords),
                             dark_after=spec.dark == "after"))
    return out


def frame_seconds(scan: Scan, stage: Stage) -> float:
    """Hardware time of one frame of ``stage``: its exposure (set, or the exposure field's
    default) + the system's readout time (s)."""
    sy = scan.system
    exp = stage.settings.get("exposure")
    if exp is None and sy.control_field("exposure") is not None:
        f = sy.control_field("exposure")
        exp = f.to_physical(f.default)
    return (exp or 0.0) + sy.timing.readout_s


def estimate_seconds(scan: Scan, stages: list[Stage]) -> float:
    """Hardware time: per frame exposure + readout, per stage the settle time (s)."""
    sy = scan.system
    settle = sy.timing.settle_s
    ls = sy.light_source.settle_s if sy.light_source else 0.0
    ch = sy.chamber.settle_s if sy.chamber else 0.0
    total, prev_t = 0.0, None
    for s in stages:
        total += s.frames_to_grab() * frame_seconds(scan, s) + settle + ls * (2 if s.dark_source == "grab" else 1)
        t = s.settings.get("temperature")
        if t is not None and t != prev_t:
            total += ch
            prev_t = t
    return total


def instruments_used(stages, scan) -> set:
    """The bench instruments a scan needs: "light" and "chamber" when a stage sets them or a
    ``<suspend>`` condition reads them (``ares.rig.factory.build_bench``: one it does not
    need may fail to answer without failing the scan). Every dark sets the light to 0 (a
    light that does not answer may be on): a declared light is always needed."""
    keys = {k for st in stages for d in (st.settings, st.dark_settings) for k in d}
    conds = {q for q, _ in (scan.suspend.conditions if getattr(scan, "suspend", None) else ())}
    used = set()
    if "light" in keys or "light" in conds:
        used.add("light")
    if "temperature" in keys or "temperature" in conds:
        used.add("chamber")
    return used
