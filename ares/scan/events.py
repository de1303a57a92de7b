"""Events the runner emits to its listeners (plain callables; no Qt).

Order for a run: ``RunStarted``, then per stage ``StageStarted``, ``FramePreview`` and
``Progress`` per frame (also for a matched dark, ``dark=True``), ``StageFinished``; at
the end exactly one of ``Done`` (status done/stopped/aborted) or ``Failed``.
``Paused``/``Resumed`` bracket a pause. Stage indices are 0-based. ``StageUpdated``: a
stage already finished was analysed again and rewritten with the defect mask a later flat
completed (``ares.scan.mask_complete``); its result replaces the one StageFinished gave.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class RunStarted:
    run_dir: str | None
    total_stages: int
    total_frames: int
    estimated_s: float


@dataclass(frozen=True)
class StageStarted:
    index: int
    total: int
    stage: object  # ares.scan.stages.Stage


@dataclass(frozen=True)
class FramePreview:
    index: int  # stage
    frame: int  # 0-based within the stack
    frames: int
    data: np.ndarray = field(repr=False)
    dark: bool = False  # frame of the matched dark stack


@dataclass(frozen=True)
class Progress:
    index: int  # current stage
    total: int  # stages
    frames_done: int  # in the whole run
    frames_total: int
    frames_per_s: float
    remaining_s: float | None

    @property
    def fraction(self) -> float:
        return self.frames_done / self.frames_total if self.frames_total else 1.0


@dataclass(frozen=True)
class StageFinished:
    index: int
    total: int
    stage: object
    result: dict  # JSON-able stage result (see ares.results.registry)
    arrays: dict = field(default_factory=dict, repr=False)  # mean/variance maps etc.


@dataclass(frozen=True)
class StageUpdated:
    index: int
    total: int
    stage: object
    result: dict  # replaces the StageFinished result of this stage
    arrays: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class Paused:
    index: int
    reason: str = ""  # why: the user paused, a condition out of tolerance, a device gone


@dataclass(frozen=True)
class Resumed:
    index: int
    seconds: float | None = None  # how long the pause lasted (a recovery's record)
    reason: str = ""


@dataclass(frozen=True)
class LinkHealth:
    """The links' trouble counters changed (retries, timeouts, lost frames, skipped lines):
    ``counts`` {part: {counter: count}} since the run started, only those not 0."""

    index: int
    counts: dict


@dataclass(frozen=True)
class Regrab:
    """The stage lost frames and is acquired again (``<frames on_loss="regrab">``)."""

    index: int
    reason: str


@dataclass(frozen=True)
class Ending:
    """No more frames: the stage loop has ended (``status`` as in ``Done``); the scan-level
    analysis, the run's closing files and then ``Done`` follow. A window gives control
    back here instead of waiting for them."""

    status: str
    stages_completed: int


@dataclass(frozen=True)
class Done:
    status: str  # "done", "stopped" or "aborted"
    run_dir: str | None
    stages_completed: int
    scan_results: dict = field(default_factory=dict)
    limit_failures: tuple = ()


@dataclass(frozen=True)
class Failed:
    message: str
    run_dir: str | None
    stages_completed: int
