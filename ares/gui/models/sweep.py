"""Sweep map model: an engine quantity per stage over the scan's sweep axes (no Qt).

ARES builds maps of noise, lag ... versus pixel voltages from 2-D scans (seed 001,
"2D scanning capability"). Each finished stage of a sweep brings its grid coordinates,
its settings and the engine's numbers for it (mean signal, temporal noise, the noise
components ...). For the latest sweep group the model gives a 1-D curve (one axis) or a
2-D grid (two axes) of the chosen quantity; it computes nothing itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ares.gui.models.observable import Observable


FULL_FRAME = "full frame"


@dataclass(frozen=True)
class SweepPoint:
    stage: int
    group: str
    coords: tuple[int, ...]
    settings: dict
    values: dict  # quantity label -> value, of the full frame
    by_view: dict = field(default_factory=dict)  # engine view -> {quantity label -> value}


def _axis_key(points: list[SweepPoint], k: int) -> str | None:
    """The setting that varies with grid index ``k`` (and only with it)."""
    if not points:
        return None
    for key in points[0].settings:
        by_index: dict[int, set] = {}
        ok = True
        for p in points:
            v = p.settings.get(key)
            if not isinstance(v, (int, float)):
                ok = False
                break
            by_index.setdefault(p.coords[k], set()).add(v)
        if not ok or any(len(vs) > 1 for vs in by_index.values()):
            continue
        if len({next(iter(vs)) for vs in by_index.values()}) == len(by_index) > 1:
            return key
    return None


class SweepModel(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.units: dict[str, str] = {}  # setting key -> unit, from the system XML
        self.points: list[SweepPoint] = []
        self.quantity: str | None = None
        self.view = "full"  # the engine view shown (the window's View selector)

    def select(self, view: str) -> None:
        if view != self.view:
            self.view = view
            if self.quantity and self.quantity not in self.quantities:  # the same quantity, named for this view
                base = self.quantity.removesuffix(f" [{FULL_FRAME}]")
                self.quantity = next((q for q in (base, f"{base} [{FULL_FRAME}]") if q in self.quantities),
                                     self.quantity)
            self._changed()

    def values(self, p: SweepPoint) -> dict:
        """A point's quantities in the shown view (none when the engine gave none for it); a
        full-frame-only quantity (the image lag, from frame means) is kept in every view, named so."""
        if self.view == "full":
            return p.values
        own = p.by_view.get(self.view, {})
        if not own:
            return {}
        return {**own, **{f"{k} [{FULL_FRAME}]": v for k, v in p.values.items() if k not in own}}

    def clear(self) -> None:
        self.points = []
        self._changed()

    def add(self, point: SweepPoint) -> None:
        if point.coords:  # a stage given again (rewritten with the completed defect mask) replaces its point,
            # in its place: the 1-D curve is drawn in stage order
            self.points = sorted([p for p in self.points if p.stage != point.stage] + [point], key=lambda p: p.stage)
            if self.quantity is None or self.quantity not in point.values:
                # noise is what ARES tunes biases for: show it first when the engine gives it
                noise = [q for q in point.values if q.startswith("temporal noise")]
                self.quantity = noise[0] if noise else next(iter(point.values), None)
            self._changed()

    def set_quantity(self, quantity: str) -> None:
        self.quantity = quantity
        self._changed()

    @property
    def quantities(self) -> list[str]:
        seen: dict[str, None] = {}
        for p in self.group_points():
            seen.update(dict.fromkeys(self.values(p)))
        return list(seen)

    def group_points(self) -> list[SweepPoint]:
        if not self.points:
            return []
        group = self.points[-1].group
        return [p for p in self.points if p.group == group]

    @property
    def ndim(self) -> int:
        pts = self.group_points()
        return len(pts[0].coords) if pts else 0

    def axes(self) -> list[tuple[str, np.ndarray]]:
        """(setting name, value at each grid index) per axis of the latest group, in increasing value
        where the values are distinct (an axis taken in shuffled order is shown in order: ``_order``)."""
        return [(name, values[_order(values)]) for name, values in self._axes()]

    def _axes(self) -> list[tuple[str, np.ndarray]]:
        pts = self.group_points()
        out = []
        for k in range(self.ndim):
            n = max(p.coords[k] for p in pts) + 1
            key = _axis_key(pts, k)
            values = np.full(n, np.nan)
            for p in pts:
                values[p.coords[k]] = p.settings.get(key, p.coords[k]) if key else p.coords[k]
            unit = self.units.get(key, "") if key else ""
            name = key.removeprefix("reg:") if key else f"index {k + 1}"
            out.append((f"{name} ({unit})" if unit else name, values))
        return out

    def curve(self) -> tuple[np.ndarray, np.ndarray]:
        """1-D sweep: (axis values, quantity) in increasing value where the values are distinct (an axis
        taken in shuffled order), else in stage order (a sweep up and down again)."""
        pts = [p for p in self.group_points() if self.quantity in self.values(p)]
        (_, values), = self._axes() or [("", np.zeros(0))]
        x = np.array([values[p.coords[0]] for p in pts], dtype=float)
        y = np.array([self.values(p)[self.quantity] for p in pts], dtype=float)
        o = _order(x)
        return x[o], y[o]

    def grid(self) -> np.ndarray:
        """2-D sweep: array [index 1, index 2] of the quantity (nan where not yet run)."""
        pts = self.group_points()
        if self.ndim != 2:
            return np.zeros((0, 0))
        shape = tuple(max(p.coords[k] for p in pts) + 1 for k in range(2))
        g = np.full(shape, np.nan)
        for p in pts:
            v = self.values(p).get(self.quantity)
            if v is not None and math.isfinite(v):
                g[p.coords] = v
        (_, v1), (_, v2) = self._axes()
        return g[np.ix_(_order(v1), _order(v2))]  # (rows and columns as ``axes`` gives their values)


def _order(values: np.ndarray) -> np.ndarray:
    """Indices putting an axis's values in increasing order where they are finite and distinct, else
    as they are."""
    v = np.asarray(values, float)
    if v.size > 1 and np.all(np.isfinite(v)) and np.unique(v).size == v.size:
        return np.argsort(v, kind="stable")
    return np.arange(v.size)
