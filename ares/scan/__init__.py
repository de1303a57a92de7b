"""Scan runner: expand a scan into stages, drive the bench, accumulate, write the run.

Public API::

    expand(scan, frames=None) -> list[Stage];  estimate_seconds(scan, stages)
    Runner(scan, out_dir=, seed=, frames=, bench=, faults=) .run() -> RunOutcome
        .add_listener(fn) .pause() .resume() .stop() .abort()
    events: RunStarted StageStarted FramePreview Progress StageFinished StageUpdated Paused Resumed Done Failed
    RunWriter, load_run(dir) -> RunRecord, scan_level_results(run), register_scan_analysis(name)
    auto_repeat(make_runner, count)

The run directory layout is documented in ``ares.scan.rundir``.
"""

from ares.scan import analyses as _builtin_analyses  # noqa: F401  (registers ptc, decomposition)
from ares.scan import emva4_analysis as _emva4_analysis  # noqa: F401  (registers emva4)
from ares.scan import emva_analysis as _emva_analysis  # noqa: F401  (registers emva1288)
from ares.scan import events
from ares.scan.results import check_limits, register_scan_analysis, scan_level_results
from ares.scan.rundir import RunRecord, RunWriter, load_run
from ares.scan.repeat import auto_repeat
from ares.scan.runner import RunOutcome, Runner
from ares.scan.stages import Stage, estimate_seconds, expand

__all__ = ["events", "check_limits", "register_scan_analysis", "scan_level_results", "RunRecord", "RunWriter",
           "load_run", "RunOutcome", "Runner", "auto_repeat", "Stage", "estimate_seconds", "expand"]
