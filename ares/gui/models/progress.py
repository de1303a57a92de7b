"""Scan progress model: "Current Stage", "Time Remaining" and the run state (no Qt)."""

from __future__ import annotations

import math

from ares.gui.models.observable import Observable

IDLE, RUNNING, PAUSED, STOPPING, FINISHING, DONE, FAILED, STOPPED = (
    "Idle", "Running", "Paused", "Stopping", "Analysing and writing the run", "Done", "Failed", "Stopped")
IDLE_TEXT = "none (Start Scan runs the loaded scan)"  # "Current Stage:" before any run


def format_remaining(seconds: float | None) -> str:
    """ARES style ``H : MM : SS``; unknown -> ``- : -- : --``."""
    if seconds is None or not math.isfinite(seconds) or seconds < 0:
        return "- : -- : --"
    s = int(round(seconds))
    return f"{s // 3600} : {s % 3600 // 60:02d} : {s % 60:02d}"


class ProgressModel(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.reset()

    def reset(self) -> None:
        self.stage = 0
        self.total = 0
        self.stage_name = ""
        self.frame = 0
        self.frames = 0
        self.fraction = 0.0
        self.seconds_remaining: float | None = 0.0
        self.state = IDLE
        self.message = ""
        self._changed()

    @property
    def stage_text(self) -> str:
        if not self.total:
            return IDLE_TEXT
        text = f"{self.stage + 1} of {self.total}"  # a count; ``stage`` is the index (from 0, as in the files)
        return f"{text} ({self.stage_name})" if self.stage_name else text

    @property
    def remaining_text(self) -> str:
        return format_remaining(self.seconds_remaining)

    def update(self, **fields) -> None:
        for k, v in fields.items():
            if not hasattr(self, k):
                raise AttributeError(k)
            setattr(self, k, v)
        self._changed()
