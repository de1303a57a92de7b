"""Photon-transfer-curve plot model: one point per finished stage (no Qt).

Each point is the engine's (mean signal above dark, temporal variance above dark) in
DN / DN² for one stage, for every view the engine computed (full frame, each region, each
Bayer phase or ADC channel); the model shows the view the window's View selector chose.
The engine's scan-level gain fit, and its verdict per level, are of the full frame. When the engine supplies a fitted gain the model keeps it so the
view can draw the shot-noise line ``variance = signal / gain_e_per_dn``; the model
computes nothing itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.gui.models.observable import Observable


@dataclass(frozen=True)
class PTCPoint:
    stage: int
    label: str
    signal_dn: float
    variance_dn2: float


FULL = "full"  # the engine's view of every pixel: the one its scan-level gain fit uses


class PTCModel(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.by_view: dict[str, list[PTCPoint]] = {}
        self.dark_dn: float | None = None
        self.gain_e_per_dn: float = math.nan
        self.fit_text = ""
        self.fit_note = ""
        self.view = FULL  # the engine view shown
        self.highlighted: int | None = None  # the stage the stage browser shows
        self.status: dict[str, tuple[str, str]] = {}  # stage name -> (fit | valid | excluded, reason)

    @property
    def points(self) -> list[PTCPoint]:
        """The shown view's points."""
        return self.by_view.get(self.view, [])

    @property
    def fitted(self) -> bool:
        """The shown view is the one the engine's gain fit and level verdicts are of."""
        return self.view == FULL

    def clear(self) -> None:
        self.by_view, self.dark_dn, self.status = {}, None, {}
        self.gain_e_per_dn, self.fit_note, self.fit_text = math.nan, "", ""
        self._changed()

    def select(self, view: str) -> None:
        """Show ``view``'s points (an engine view name: "full", a region's name, "cfa_R", "adc1" ...)."""
        if view != self.view:
            self.view = view
            self._changed()

    def set_dark(self, dark_dn: float) -> None:
        """The dark level, for the caption (points are already above dark)."""
        self.dark_dn = float(dark_dn)
        self._changed()

    def add(self, stage: int, label: str, signal_dn: float, variance_dn2: float, view: str = FULL) -> None:
        """One point per stage and view: a stage given again (its result rewritten once a flat
        completed the defect mask, ares.scan.mask_complete) replaces its point."""
        pts = [p for p in self.by_view.get(view, []) if p.stage != stage]
        pts.append(PTCPoint(stage, label, float(signal_dn), float(variance_dn2)))
        self.by_view[view] = sorted(pts, key=lambda p: p.stage)
        self._changed()

    def set_status(self, level_status: list[dict]) -> None:
        """The engine's verdict per level: in the fit, valid but outside it, or excluded."""
        self.status = {str(d.get("stage")): (str(d.get("status", "")), str(d.get("reason") or ""))
                       for d in level_status if isinstance(d, dict)}
        self._changed()

    def groups(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Points by the engine's verdict (``fit``, ``valid``, ``excluded``; ``pending``
        until the scan-level fit has run; ``view`` in a view the engine did not fit), only
        those drawable on log axes."""
        out: dict[str, tuple[list, list]] = {}
        for p in self.points:
            if p.signal_dn > 0 and p.variance_dn2 > 0:
                key = (self.status.get(p.label, ("pending", ""))[0] or "pending") if self.fitted else "view"
                xs, ys = out.setdefault(key, ([], []))
                xs.append(p.signal_dn)
                ys.append(p.variance_dn2)
        return {k: (np.array(x), np.array(y)) for k, (x, y) in out.items()}

    def highlight(self, stage: int | None) -> None:
        if stage != self.highlighted:
            self.highlighted = stage
            self._changed()

    def set_fit(self, gain_e_per_dn: float, note: str = "", text: str = "") -> None:
        """The engine's fitted gain (draws the shot-noise line) and ``text``: the figures
        with their SEs as the engine formats them (shown; never a bare number)."""
        self.gain_e_per_dn = float(gain_e_per_dn)
        self.fit_text = text
        self.fit_note = note
        self._changed()

    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        """Signal above dark and variance of the points, as arrays."""
        x = np.array([p.signal_dn for p in self.points], dtype=np.float64)
        y = np.array([p.variance_dn2 for p in self.points], dtype=np.float64)
        return x, y

    def loglog(self) -> tuple[np.ndarray, np.ndarray]:
        """log10 of the points that can be drawn on log-log axes (both > 0)."""
        x, y = self.xy()
        ok = (x > 0) & (y > 0)
        return np.log10(x[ok]), np.log10(y[ok])

    def fit_line(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Shot-noise line over the points' signal range, when a gain is known."""
        x, _ = self.xy()
        x = x[x > 0]
        if x.size == 0 or not (math.isfinite(self.gain_e_per_dn) and self.gain_e_per_dn > 0):
            return None
        xs = np.array([x.min(), x.max()])
        return xs, xs / self.gain_e_per_dn
