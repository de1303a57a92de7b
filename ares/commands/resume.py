"""``ares resume RUN_DIR``: continue an interrupted run from its first missing stage.

The run directory alone says what to do (``ares.scan.resume``): the verbatim XML, the
seed and frame override, the committed stages, the bench state and the defect mask. The
missing stages are appended to the same directory; progress, Ctrl-C/SIGTERM handling,
summary and exit codes are those of ``ares run``. A run whose stages are complete but
whose reports were cut short (``reports incomplete``) gets its reports written. A run that is done, still running, or
whose directory was edited is refused with one sentence.

The manifest (``ares.rundir.manifest``) is checked first: a file of the run itself (XML,
stages, arrays, results) altered refuses the resume, naming every such file -- continuing
would build on them and record them as the run's own. A report altered since ARES wrote
it is named on stderr with its fate: written anew by the resume, or left as found and still
recorded as altered (the resume's new manifest keeps its old entry: an altered file is
never re-blessed in silence); a recorded file that is missing is written again by the
resume (a stage taken out is acquired again, a report written), or named and still
recorded as missing.
"""

from __future__ import annotations

import sys

NAME = "resume"
HELP = "continue an interrupted run from its first missing stage (same XML, seed, bench state)"


def add_arguments(p) -> None:
    p.add_argument("run_dir", help="the run directory of an interrupted, stopped or failed run")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the final summary as JSON on stdout")


def _checked(d):
    """The run's altered reports and missing files ({relative path: (what, recorded entry,
    SHA-256 now or None)}); a run file altered: refused, one sentence naming them all."""
    from ares.errors import InputError
    from ares.rundir import manifest

    recorded = manifest.load(d)
    found = manifest.problems(d)
    own = [(rel, what) for rel, what in found if recorded.get(rel, {}).get("by", manifest.RUN) != manifest.REPORT
           and what != "missing"]
    if own:
        raise InputError(manifest.sentence(d, own) + "; a resume would continue from them and record them as the "
                         "run's own: restore them, or `ares rerun` repeats the run from its verbatim XML")
    return {rel: (what, recorded[rel], manifest.file_sha256(d / rel) if (d / rel).is_file() else None)
            for rel, what in found if (rel, what) not in own}


def _say_fates(d, reports: dict) -> None:
    """Each altered or missing report named with what the resume did with it; one it left
    as found keeps its old manifest entry."""
    from ares.rundir import manifest

    kept = {}
    for rel, (what, entry, sha_before) in reports.items():
        p = d / rel
        if p.is_file() and manifest.file_sha256(p) != sha_before:
            if what == "missing":
                continue  # (a missing file the resume wrote: its job, nothing altered to hide)
            fate = "written anew by the resume"
        else:
            fate = "left as found, and still recorded as altered (`ares report` writes it anew)" if p.is_file() \
                else "still missing (`ares report` writes it)"
            kept[rel] = entry
        was = what.replace("altered", "altered after ARES wrote it", 1)
        print(f"note: {p} was {was}: {fate}", file=sys.stderr)
    manifest.restore(d, kept)


def run(args) -> int:
    from pathlib import Path

    from ares.commands.run import execute
    from ares.rundir.record import load_run
    from ares.scan.resume import resumable

    from ares.rundir.state import REPORTS_INCOMPLETE, effective_status

    from ares.commands.run_signals import refuse_if_stopped

    run_ = load_run(args.run_dir)
    refuse_if_stopped(f"{run_.dir} is as it was")
    reports = _checked(run_.dir)
    finishing = effective_status(run_.meta)[0] == REPORTS_INCOMPLETE  # stages complete, reports not: write them
    stages = None if finishing else resumable(run_)
    try:
        if finishing:
            from ares.commands.run import finish_reports

            return finish_reports(run_, args)
        meta = run_.meta
        return execute(run_.scan, args, seed=meta.get("seed"), frames=meta.get("frames_override"),
                       argv=list(meta.get("argv") or []), out_dir=Path(args.run_dir), resume_from=stages)
    finally:
        if reports:
            _say_fates(run_.dir, reports)
