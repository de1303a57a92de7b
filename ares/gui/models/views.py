"""Which pixels and which stage every result tab shows (no Qt).

``ViewModel``: one choice for all result tabs -- automatic (the first active region,
else the full frame), the full frame, a region of the RoA table, a Bayer phase or an
ADC channel. The Bayer phases and ADC channels are the engine's own views
(``ares.scan.stage_analysis.views``: ``cfa_R`` ..., ``adc0`` ...), so a tab showing "ADC
channel 1" looks at exactly the pixels the engine decomposed under that name.

``StageStore``: the finished stages of the run (their per-pixel mean and variance as
float32 for display) so that any of them, not only the latest, can be shown. Arrays of
the oldest stages are dropped past a memory budget; their rows stay listed.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from ares.gui.models.observable import Observable
from ares.gui.models.regions import Region, RegionSet

AUTO, FULL = "auto", "full"
BUDGET_BYTES = 1 << 30


def channel_label(name: str, interleave: str = "column") -> str:
    if name.startswith("cfa_"):
        return f"Bayer {name[4:]}"
    if name.startswith("adc"):
        what = "rows" if interleave == "row" else "columns"
        return f"ADC channel {int(name[3:])} ({what} {name[3:]} + k x channels)"
    return name


class ViewModel(Observable):
    def __init__(self, regions: RegionSet) -> None:
        super().__init__()
        self.regions = regions
        self.channels: dict[str, tuple[slice, slice]] = {}
        self.labels: dict[str, str] = {}
        self.region_names: dict[int, str] = {}  # RoA row -> the engine's view name in the last run
        self.selected = AUTO

    def set_channels(self, views: dict[str, tuple[slice, slice]], labels: dict[str, str] | None = None) -> None:
        """The engine's Bayer-phase and ADC-channel views of the loaded scan."""
        self.channels = {k: v for k, v in views.items() if k.startswith(("cfa_", "adc"))}
        self.labels = {k: (labels or {}).get(k, channel_label(k)) for k in self.channels}
        if self.selected not in (AUTO, FULL) and not self.selected.startswith("roa") \
                and self.selected not in self.channels:
            self.selected = AUTO
        self._changed()

    def choices(self) -> list[tuple[str, str]]:
        out = [(AUTO, "Automatic (first active region, else full frame)"), (FULL, "Full frame")]
        out += [(f"roa{i}", f"Region {i + 1}: {r.width} x {r.height} at ({r.x}, {r.y})")
                for i, r in self.regions.active()]
        out += [(k, self.labels[k]) for k in self.channels]
        return out

    def select(self, key: str | None) -> None:
        key = key or AUTO
        if key != self.selected:
            self.selected = key
            self._changed()

    def resolve(self, shape) -> tuple[str, Region | tuple[slice, slice] | None]:
        """(key, region or slices) of the current choice; a choice that no longer exists
        (region switched off) falls back to automatic."""
        key = self.selected
        active = dict(self.regions.active())
        if key.startswith("roa") and int(key[3:]) in active:
            return key, active[int(key[3:])]
        if key in self.channels:
            return key, self.channels[key]
        if key == FULL or not active:
            return FULL, None
        i = min(active)
        return f"roa{i}", active[i]

    def pixels(self, array: np.ndarray) -> np.ndarray | None:
        """The chosen view's pixels of a 2-D array (None when the region lies outside)."""
        _, what = self.resolve(array.shape)
        if what is None:
            return array
        if isinstance(what, Region):
            return what.crop(array)
        part = array[what]
        return part if part.size else None

    def channel_mask(self, shape) -> np.ndarray | None:
        """Boolean mask of the chosen Bayer phase or ADC channel (None for other views)."""
        if self.selected not in self.channels:
            return None
        mask = np.zeros(shape, bool)
        mask[self.channels[self.selected]] = True
        return mask

    def label(self, shape) -> str:
        key, _ = self.resolve(shape)
        if key == FULL:
            return "full frame"
        if key.startswith("roa"):
            return f"region {int(key[3:]) + 1}"
        return self.labels.get(key, key)

    def engine_view(self, shape) -> str:
        """The engine's name for the chosen pixels (a key of a stage result's views)."""
        key, _ = self.resolve(shape)
        if key.startswith("roa"):
            return self.region_names.get(int(key[3:]), FULL)
        return key


class StageStore(Observable):
    """Finished stages, in order; ``shown`` is the one the tabs draw (None: the latest)."""

    def __init__(self, budget_bytes: int = BUDGET_BYTES) -> None:
        super().__init__()
        self.budget = budget_bytes
        self.results: OrderedDict[int, object] = OrderedDict()
        self.shown: int | None = None

    def clear(self) -> None:
        self.results.clear()
        self.shown = None
        self._changed()

    def add(self, ev) -> None:
        from dataclasses import replace

        ev = replace(ev, mean=np.asarray(ev.mean, np.float32), variance=np.asarray(ev.variance, np.float32))
        self.results[ev.stage] = ev
        used = sum(r.mean.nbytes + r.variance.nbytes for r in self.results.values() if r.mean is not None)
        for k, r in self.results.items():  # oldest first; never the one just added
            if used <= self.budget or k == ev.stage:
                break
            if r.mean is not None and k != self.shown:
                used -= r.mean.nbytes + r.variance.nbytes
                self.results[k] = replace(r, mean=None, variance=None)
        self._changed()

    def show(self, stage: int | None) -> None:
        self.shown = stage if stage in self.results else None
        self._changed()

    def current(self):
        if not self.results:
            return None
        if self.shown is not None:
            return self.results[self.shown]
        return next(reversed(self.results.values()))

    @property
    def following_latest(self) -> bool:
        return self.shown is None
