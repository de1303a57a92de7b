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


def threshold_defaults() -> list[tuple[str, str]]:
    """Every defect threshold and limit with its default, as the table shows them."""
    from ares.analysis.defects import DefectThresholds

    return [(k, "" if v is None else f"{v:g}") for k, v in DefectThresholds().to_dict().items()]


def reclassify(run_dir: str, overrides: dict[str, str]) -> tuple[dict[str, int], int, str]:
    """Re-run the defect classification of a finished run from its directory alone with
    ``overrides`` replacing the scan's thresholds: (counts, pixels, caption)."""
    from ares.errors import InputError
    from ares.scan.analyses import defects
    from ares.scan.rundir import load_run

    if not run_dir:
        raise InputError("no run directory yet: run a scan that classifies defects first")
    run = load_run(run_dir)
    res = defects(run, overrides)
    if "counts" not in res:
        raise InputError(f"{run_dir}: defects {res.get('status', 'not available')} ({res.get('note', '')})")
    counts = {k: v for k, v in res["counts"].items() if v is not None}
    rows, cols = run.system.sensor.rows, run.system.sensor.cols
    what = ", ".join(f"{k} = {v}" for k, v in overrides.items()) or "the scan's thresholds"
    return counts, rows * cols, f"re-classified from {run_dir} with {what}"
