"""Defect Counts table model: one row per defect class the engine reported (no Qt)."""

from __future__ import annotations

from dataclasses import dataclass

from .observable import Observable


@dataclass(frozen=True)
class DefectRow:
    name: str
    count: int
    ppm: float
    criterion: str = ""


class DefectCountsModel(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.rows: list[DefectRow] = []
        self.caption = ""

    def set_counts(self, counts: dict[str, int], total_pixels: int,
                   criteria: dict[str, str] | None = None, caption: str = "") -> None:
        criteria = criteria or {}
        total = max(int(total_pixels), 1)
        self.rows = [
            DefectRow(name, int(n), 1e6 * int(n) / total, criteria.get(name, ""))
            for name, n in counts.items()
        ]
        self.caption = caption
        self._changed()

    def clear(self) -> None:
        self.rows, self.caption = [], ""
        self._changed()
