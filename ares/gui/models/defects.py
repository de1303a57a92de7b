"""Defect Counts table model: one row per defect class the engine reported (no Qt)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.gui.models.observable import Observable


# one colour per class, shared by the table and the overlay on the images
DEFECT_COLORS = {"hot": (220, 30, 30), "warm": (240, 140, 0), "dead": (0, 0, 0), "stuck": (150, 60, 200),
                 "noisy": (30, 120, 220), "rts": (0, 170, 170), "low_response": (120, 120, 0),
                 "high_response": (20, 160, 60)}


@dataclass(frozen=True)
class DefectRow:
    name: str
    count: int | None  # None: the class could not be tested with this run (the criterion says why)
    ppm: float
    criterion: str = ""

    @property
    def count_text(self) -> str:
        return "n/a" if self.count is None else str(self.count)

    @property
    def ppm_text(self) -> str:
        return "n/a" if self.count is None else f"{self.ppm:.1f}"


class DefectCountsModel(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.rows: list[DefectRow] = []
        self.caption = ""
        self.map: dict | None = None  # {"shape", "locations": {class: [[x, y], ...]}, "bad_column_x", "bad_row_y"}
        self.overlay = False  # draw the map over the images
        self.thresholds: dict[str, str] = {}  # the run's own thresholds (the scan's <defects>), shown in the table

    def set_counts(self, counts: dict[str, int | None], total_pixels: int,
                   criteria: dict[str, str] | None = None, caption: str = "") -> None:
        criteria = criteria or {}
        total = max(int(total_pixels), 1)
        self.rows = [
            DefectRow(name, None if n is None else int(n), math.nan if n is None else 1e6 * int(n) / total,
                      criteria.get(name, ""))
            for name, n in counts.items()
        ]
        self.caption = caption
        self._changed()

    def set_map(self, defect_map: dict | None) -> None:
        self.map = defect_map
        self._changed()

    def set_overlay(self, on: bool) -> None:
        self.overlay = bool(on)
        self._changed()

    def points(self) -> dict[str, np.ndarray]:
        """Class -> (N, 2) array of [x, y] pixel positions, when the overlay is on."""
        if not self.overlay or not self.map:
            return {}
        return {cls: np.asarray(pts, dtype=np.float64).reshape(-1, 2)
                for cls, pts in (self.map.get("locations") or {}).items() if pts}

    def set_thresholds(self, values: dict[str, float]) -> None:
        """The thresholds the run used (the scan's ``<defects>``; the others their defaults)."""
        self.thresholds = {str(k): f"{float(v):g}" for k, v in values.items()}
        self._changed()

    def clear(self) -> None:
        self.rows, self.caption, self.map, self.thresholds = [], "", None, {}
        self._changed()


def threshold_defaults() -> list[tuple[str, str]]:
    """Every defect threshold and limit with its default, as the table shows them."""
    from ares.analysis.defects import DefectThresholds

    return [(k, "" if v is None else f"{v:g}") for k, v in DefectThresholds().to_dict().items()]


def reclassify(run_dir: str, overrides: dict[str, str]) -> tuple[dict[str, int], int, str]:
    """Re-run the defect classification of a finished run from its directory alone with
    ``overrides`` replacing the scan's thresholds: (counts, pixels, caption)."""
    from ares.errors import InputError
    from ares.results.analyses import defects
    from ares.rundir.record import load_run

    if not run_dir:
        raise InputError("no run directory yet: run a scan that classifies defects first")
    run = load_run(run_dir)
    res = defects(run, overrides)
    if "counts" not in res:
        raise InputError(f"{run_dir}: defects {res.get('status', 'not available')} ({res.get('note', '')})")
    rows, cols = run.system.sensor.rows, run.system.sensor.cols
    what = ", ".join(f"{k} = {v}" for k, v in overrides.items()) or "the scan's thresholds"
    return dict(res["counts"]), rows * cols, f"re-classified from {run_dir} with {what}", res
