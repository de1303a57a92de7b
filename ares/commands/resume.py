"""``ares resume RUN_DIR``: continue an interrupted run from its first missing stage.

The run directory alone says what to do (``ares.scan.resume``): the verbatim XML, the
seed and frame override, the committed stages, the bench state and the defect mask. The
missing stages are appended to the same directory; progress, Ctrl-C/SIGTERM handling,
summary and exit codes are those of ``ares run``. A run whose stages are complete but
whose reports were cut short (``reports incomplete``) gets its reports written. A run that is done, still running, or
whose directory was edited is refused with one sentence.
"""

from __future__ import annotations

NAME = "resume"
HELP = "continue an interrupted run from its first missing stage (same XML, seed, bench state)"


def add_arguments(p) -> None:
    p.add_argument("run_dir", help="the run directory of an interrupted, stopped or failed run")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the final summary as JSON on stdout")


def run(args) -> int:
    from pathlib import Path

    from ares.commands.run import execute
    from ares.rundir.record import load_run
    from ares.scan.resume import resumable

    from ares.rundir.state import REPORTS_INCOMPLETE, effective_status

    from ares.commands.run_signals import refuse_if_stopped

    run_ = load_run(args.run_dir)
    refuse_if_stopped(f"{run_.dir} is as it was")
    if effective_status(run_.meta)[0] == REPORTS_INCOMPLETE:  # stages complete, reports not: write them
        from ares.commands.run import finish_reports

        return finish_reports(run_, args)
    stages = resumable(run_)
    meta = run_.meta
    return execute(run_.scan, args, seed=meta.get("seed"), frames=meta.get("frames_override"),
                   argv=list(meta.get("argv") or []), out_dir=Path(args.run_dir), resume_from=stages)
