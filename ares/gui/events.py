"""The events the GUI draws from (no Qt).

These mirror what the scan runner emits (DESIGN.md, data flow step 3): stage started,
frame preview, stage result, progress with time remaining, done, failed -- plus
stopped. ``ares.gui.engine`` turns runner events into these, so the views depend on
this one small vocabulary only.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class StageStarted:
    stage: int  # the stage index, from 0 as in the files (stages/0000.json) and every surface
    total: int
    name: str = ""
    frames: int = 0
    settings: dict = field(default_factory=dict)


@dataclass(frozen=True)
class FramePreview:
    stage: int
    frame: int  # 1-based within the stage
    frames: int
    image: np.ndarray
    dark: bool = False  # a frame of the stage's matched dark stack


@dataclass(frozen=True)
class StageResult:
    """Per-pixel temporal mean and variance (DN, DN²) of a finished stage."""

    stage: int
    name: str
    mean: np.ndarray
    variance: np.ndarray
    frames: int = 0
    dark: bool = False
    settings: dict = field(default_factory=dict)
    defects: dict | None = None  # {class name: count}
    # the engine's photon-transfer point for this stage: (mean signal above dark in DN,
    # temporal variance above dark in DN²), None for a dark stage or when not computed
    ptc_point: tuple[float, float] | None = None
    ptc_view: str = ""  # which pixels the engine used for ptc_point ("full", a region ...)
    # the same point for every view the engine computed (view name -> point): the PTC tab
    # follows the View selector like every other tab
    ptc_points: dict = field(default_factory=dict)
    group: str = ""  # the sweep (or single stage) this stage belongs to
    coords: tuple = ()  # grid indices within a sweep; () for a single stage
    quantities: dict = field(default_factory=dict)  # engine numbers for the sweep map: label -> value
    view_quantities: dict = field(default_factory=dict)  # ... of every view: view -> {label -> value}
    components: dict = field(default_factory=dict)  # view -> {"components": {...}, "dark_components": {...}}
    summary: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Progress:
    stage: int
    total: int
    fraction: float
    seconds_remaining: float | None = None
    at: float = field(default_factory=time.monotonic)  # when the engine computed it (the window counts down from there)


@dataclass(frozen=True)
class RunInfo:
    """Sent once when a run starts: where it writes and how long it should take."""

    run_dir: str | None = None
    total_stages: int = 0
    estimated_s: float | None = None


@dataclass(frozen=True)
class Ending:
    """The scan takes no more frames (done, stopped or aborted); its scan-level analysis
    and reports follow in the background, then ``Done`` or ``Stopped``."""

    status: str = "done"
    stages_completed: int = 0


@dataclass(frozen=True)
class Done:
    run_dir: str | None = None
    summary: dict = field(default_factory=dict)  # e.g. gain_e_per_dn, defects, results
    limit_failures: tuple = ()
    limits: str = ""  # ares.results.registry.limits_verdict's line ("limits: none set", ...)


@dataclass(frozen=True)
class Stopped:
    message: str = "stopped"
    aborted: bool = False
    run_dir: str | None = None
    summary: dict = field(default_factory=dict)  # the stopped run's own scan-level figures (as Done's)


@dataclass(frozen=True)
class ReportsWritten:
    """A stopped or aborted run's reports are finished (its ``Stopped`` said they were
    being written): ``message`` says where and in what state (run.json's ``reports``)."""

    message: str
    state: str = "complete"


@dataclass(frozen=True)
class Failed:
    message: str  # one sentence, never a traceback


@dataclass(frozen=True)
class Health:
    """Recovery in sight: ``kind`` "paused", "resumed", "regrab" or "link"; ``text`` the line
    the terminal prints (why, how long, the links' trouble counters)."""

    kind: str
    stage: int  # the stage index, from 0
    text: str


GuiEvent = (RunInfo | StageStarted | FramePreview | StageResult | Progress | Ending | Done | Stopped | ReportsWritten
            | Failed | Health)
