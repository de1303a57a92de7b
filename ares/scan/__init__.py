"""Scan runner: expand a scan into stages, drive the bench, accumulate, write the run.

Public API::

    expand(scan, frames=None) -> list[Stage];  estimate_seconds(scan, stages)
    Runner(scan, out_dir=, seed=, frames=, bench=, faults=) .run() -> RunOutcome
        .add_listener(fn) .pause() .resume() .stop() .abort()
    events: RunStarted StageStarted FramePreview Progress StageFinished StageUpdated Paused Resumed Regrab
            LinkHealth Ending Done Failed
    RunWriter, load_run(dir) -> RunRecord, scan_level_results(run), register_scan_analysis(name)
    auto_repeat(make_runner, count)

The run directory layout is documented in ``ares.rundir.writer``.

May import ``report``, ``results``, ``rundir``, ``rig``, ``protocol``, ``sim``, ``hardware``,
``analysis`` and the base modules."""

from ares.scan import events
from ares.results.registry import check_limits, register_scan_analysis, scan_level_results
from ares.rundir.writer import RunWriter
from ares.rundir.record import RunRecord, load_run
from ares.scan.repeat import auto_repeat
from ares.scan.runner import Runner
from ares.scan.stage_loop import RunOutcome
from ares.scan.stages import Stage, estimate_seconds, expand

__all__ = ["events", "check_limits", "register_scan_analysis", "scan_level_results", "RunRecord", "RunWriter",
           "load_run", "RunOutcome", "Runner", "auto_repeat", "Stage", "estimate_seconds", "expand"]
