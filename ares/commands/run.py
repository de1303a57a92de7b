"""``ares run SCAN``: run a scan (simulated bench by default), write a run directory.

Exit codes: 0 success, 2 invalid input, 3 hardware failure, 4 failed limits,
130 stopped/aborted (Ctrl-C once = stop after the current stage, twice = abort).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from ares.errors import InputError, interruption
from ares.commands.run_summary import print_precision, print_summary  # noqa: F401 (tests import them here)
from ares.commands.run_signals import (ReportsAbandoned, Signals, abandon_reports, complete_anyway, finished_anyway,
                                      refuse_if_stopped)

CLAIM = ".ares-claim"  # ares.rundir.files.CLAIM (not imported here: `ares --help` stays light)

NAME = "run"
HELP = "run a scan XML on its system (the simulator by default) and write a run directory"


def add_arguments(parser) -> None:
    parser.add_argument("scan", metavar="SCAN", help="scan XML file")
    add_common(parser)
    parser.add_argument("--system", metavar="PROTOCOL", help="system XML to use instead of the scan's <system href>")
    parser.add_argument("--frames", type=int, metavar="N", help="override every stage's frame count (N >= 2)")
    parser.add_argument("--seed", type=int, metavar="N", help="simulator seed (default: the system's <simulator seed>)")
    parser.add_argument("--dry-run", action="store_true", help="list the stages and estimate the duration; touch nothing")
    parser.add_argument("--repeat", type=int, default=1, metavar="N",
                        help="auto-repeat: run the scan N times (0 = until stopped), one run directory each")
    parser.add_argument("--sim-fault", action="append", default=[], metavar="KEY=N",
                        help="inject a simulator fault (disconnect_after_frames=N, short_frame_at=N, "
                             "frame_delay_ms=N; on a wire-emulated system also usb_drop_at=N, i2c_nack_at=N, "
                             "light_timeout_at=N... see FORMAT.md); for tests")


def add_common(parser) -> None:
    parser.add_argument("--out", metavar="DIR",
                        help="run directory (default: runs/<scan>_<time>); if DIR is already a run directory "
                             "DIR_2, DIR_3... is used, if it is another non-empty folder DIR/<scan>_<time>")
    parser.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    parser.add_argument("--json", action="store_true", help="print the final summary as JSON on stdout")


def _faults(items: list[str]) -> dict | None:
    out = {}
    for it in items:
        k, _, v = it.partition("=")
        try:
            out[k.strip()] = int(v)
        except ValueError:
            try:  # a time constant (light_tau_s=0.3)
                out[k.strip()] = float(v)
            except ValueError:
                raise InputError(f"--sim-fault expects KEY=N, got '{it}'") from None
    return out or None


def default_out(scan_name: str, parent: Path = Path("runs")) -> Path:
    """The first free ``PARENT/<scan>_<time>[_k]`` (free in ``parent``: the folder it goes in)."""
    return _first_free(parent / f"{scan_name}_{time.strftime('%Y%m%d-%H%M%S')}")


def _first_free(base: Path, k: int = 1) -> Path:
    p = base if k == 1 else base.with_name(f"{base.name}_{k}")
    while p.exists():
        k += 1
        p = base.with_name(f"{base.name}_{k}")
    return p


def resolve_out(out: str | Path | None, scan_name: str) -> Path:
    """``--out DIR``: DIR itself when new or empty; a sibling ``DIR_2``, ``DIR_3``... when DIR
    is already a run directory; a new ``DIR/<scan>_<time>`` when DIR is another non-empty
    folder (so ``--out runs`` works again and again). No ``--out``: ``runs/<scan>_<time>``."""
    if out is None:
        return default_out(scan_name)
    p = Path(out)
    if not p.exists() or (p.is_dir() and not any(p.iterdir())):
        return p
    if not p.is_dir():
        raise InputError(f"--out {p}: exists and is not a directory")
    if (p / "run.json").exists() or (p / CLAIM).exists():  # a run directory, or one being made
        return _first_free(p, 2)
    return default_out(scan_name, p)


def claim_out(out, scan_name: str, tries: int = 10000) -> Path:
    """``resolve_out`` and claim the directory (created exclusively, ``claim_run_dir``); a
    concurrent run that took the name first moves this one to the next free name (never
    into the other run's folder). Each refusal means that name now exists, so the next
    one is new: any number of concurrent runs into the same --out get one each."""
    from ares.rundir.files import claim_run_dir

    if out is not None and not str(out).strip():
        raise InputError("--out: the run directory must not be an empty path")
    for _ in range(tries):
        try:
            p = resolve_out(out, scan_name)
            claim_run_dir(p)
            return p
        except InputError as exc:  # taken by a concurrent run between resolve and claim: next name
            if "being written by another run" not in str(exc) and "exists and is not empty" not in str(exc):
                raise
        except OSError as exc:  # a name too long, a path through a file, no permission to look
            raise InputError(f"--out {out}: not usable as a run directory ({exc.strerror or exc})") from None
    raise InputError(f"--out {out}: no free run directory after {tries} tries (other runs are writing there)")


def fmt_s(s: float | None) -> str:
    if s is None or not math.isfinite(s):
        return "--:--:--"
    s = int(round(s))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


class ProgressBar:
    """Listener drawing ``stage i/n name [####....] 42% 120 frames/s ETA h:mm:ss`` on stderr."""

    def __init__(self, stream=None, width: int = 24):
        self.stream, self.width = stream or sys.stderr, width
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self.last = 0.0
        self.stage = None

    def __call__(self, e) -> None:
        from ares.scan import events as ev

        if isinstance(e, ev.StageStarted):
            self.stage = e
            if not self.tty:
                self.stream.write(f"stage {e.index} {e.stage.name} ({e.index + 1} of {e.total}; {e.stage.scene}, "
                                  f"{e.stage.frames} frames)\n")
                self.stream.flush()
        elif isinstance(e, ev.Progress) and self.tty:
            now = time.monotonic()
            if now - self.last < 0.1 and e.frames_done < e.frames_total:
                return
            self.last = now
            n = int(self.width * e.fraction)
            name = self.stage.stage.name if self.stage else ""
            self.stream.write(f"\rstage {e.index} {name:<14.14} {e.index + 1:>3}/{e.total} [{'#' * n}{'.' * (self.width - n)}] "
                              f"{100 * e.fraction:3.0f}% {e.frames_per_s:6.1f} frames/s ETA {fmt_s(e.remaining_s)}")
            self.stream.flush()
        elif isinstance(e, (ev.Paused, ev.Resumed, ev.Regrab, ev.LinkHealth)):
            self._health(e, ev)
        elif isinstance(e, (ev.Done, ev.Failed)) and self.tty:
            self.stream.write("\n")
            self.stream.flush()


    def _health(self, e, ev) -> None:
        """Recovery in sight: a line for every pause, resume, re-grab and change of the links'
        trouble counters (the bar, on a terminal, goes on below it)."""
        text = health_line(e)
        if text:
            self.stream.write(("\n" if self.tty else "") + text + "\n")
            self.stream.flush()


def health_line(e) -> str | None:
    """The line for a Paused/Resumed/Regrab/LinkHealth event (the terminal's and the window's)."""
    from ares.hardware.link_stats import trouble_text
    from ares.scan import events as ev

    where = f"stage {e.index}"  # the stage index, from 0 as in the files
    if isinstance(e, ev.Paused):
        return f"Paused at {where}: {e.reason or 'paused'}"
    if isinstance(e, ev.Resumed):
        return f"Resumed at {where}" + (f" after {e.seconds:.3g} s" if e.seconds is not None else "")
    if isinstance(e, ev.Regrab):
        return f"Regrab of {where}: {e.reason}"
    if isinstance(e, ev.LinkHealth) and e.counts:
        return f"link: {trouble_text(e.counts)}"
    return None


def dry_run(scan, frames: int | None, seed: int | None = None, out=None, out_dir=None) -> None:
    """List the stages and the time and memory the run needs, after the checks ``ares run``
    makes before it starts (``ares.scan.preflight``: what a run would refuse, this refuses)."""
    out = out or sys.stdout
    from ares.scan import estimate_seconds
    from ares.scan.preflight import check_run

    plan = check_run(scan, frames, seed, out_dir)
    stages = plan.stages
    out.write(f"scan '{scan.name}' on system '{scan.system.name}' "
              f"({scan.system.sensor.cols}x{scan.system.sensor.rows}): {len(stages)} stages\n")
    total = 0
    for s in stages:
        dark = ""
        if s.dark_source == "grab":
            dark = f" + {s.dark_frames} dark"
        elif s.dark_source == "reuse":
            dark = " + dark (reused)"
        sets = ", ".join(f"{k.removeprefix('reg:')}={v:g}" for k, v in s.settings.items())
        out.write(f"  {s.index:4d}  {s.name:<18} {s.scene:<4} {s.frames:4d} frames{dark:<18} {sets}\n")
        total += s.frames_to_grab()
    est = estimate_seconds(scan, stages)
    out.write(f"total: {total} frames, estimated {fmt_s(est)} ({est:.1f} s) of exposure, readout and settling\n")
    out.write(plan.memory_note() + "\n" + plan.disk_note() + "\n")


def execute(scan, args, *, seed, frames, faults=None, argv=None, out_dir=None, resume_from=None) -> int:
    """Run ``scan`` with the CLI's progress, Ctrl-C handling, summary and exit code
    (``resume_from``: the committed stages of the interrupted run in ``out_dir``)."""
    from ares.scan import Runner
    from ares.scan.preflight import check_run

    from ares.rundir.state import quiet_unraisable_storage_errors

    quiet_unraisable_storage_errors()
    refuse_if_stopped("nothing was written" if resume_from is None else f"{out_dir} is as it was")
    if resume_from is None:
        check_run(scan, frames, seed, out_dir)  # refused before a run directory exists (Runner checks again)
        out_dir = claim_out(out_dir, scan.name)
    if scan.precision is not None and frames is None and resume_from is None:
        from ares.scan.precision import PrecisionRunner  # pilot, then the frames the targets need

        runner = PrecisionRunner(scan, out_dir=out_dir, seed=seed, argv=argv, faults=faults,
                                 defer_reports=not args.json)
    else:
        runner = Runner(scan, out_dir=out_dir, seed=seed, frames=frames, faults=faults, argv=argv,
                        resume_from=resume_from, defer_reports=not args.json)
    if not args.quiet:
        runner.add_listener(ProgressBar())
    # Ctrl-C, SIGTERM (kill, a job scheduler) and SIGHUP (the terminal closed) end a run
    # like a stop: the stage in flight finishes, run.json says so; a second one aborts.
    # While the reports are written, one abandons them (``Signals``)
    sigs = Signals(runner).install()
    helper = None
    if scan.output.pdf and not args.json:  # the report helper imports matplotlib during the scan
        from ares.report import pdf_parts

        helper = pdf_parts.start(out_dir, background=True)
    t0 = time.monotonic()
    try:
        try:
            outcome = runner.run()
        except BaseException:
            if helper is not None:
                helper.kill()
            raise
        sigs.phase = "reports"
        seconds = time.monotonic() - t0
        if args.json:
            json.dump(_json_summary(outcome, scan, seconds), sys.stdout, indent=1, default=str)
            sys.stdout.write("\n")
        else:
            # the key figures before the report (the PDF takes seconds)
            print_summary(outcome, scan, seconds, resumed=len(resume_from or ()))
            if getattr(runner, "report", None):
                print_precision(runner.report)
            sys.stdout.flush()
            err = runner.write_reports(helper)
            if err:
                print(f"report: not written ({err})")
            elif outcome.run_dir and scan.output.pdf and not args.quiet:
                print(f"report: {Path(outcome.run_dir) / 'report.pdf'}")
        if helper is not None:
            helper.close()  # (when no report was written: --json, nothing pending)
        if sigs.received:  # a signal whose exception Python lost on the way: the reports are written
            return finished_anyway(sigs, outcome.run_dir, getattr(args, "command", None) or "run")
        if sigs.hits and outcome.status == "done":  # a stop after the last stage: complete, yet told
            return complete_anyway(sigs, outcome.run_dir, getattr(args, "command", None) or "run")
    except ReportsAbandoned as exc:
        return abandon_reports(exc, outcome.run_dir, helper, getattr(args, "command", None) or "run",
                               len(outcome.stages))
    except Exception as exc:  # the signal cut a library short and it raised its own error over it
        sig = interruption(exc)  # (an import of matplotlib for the summary: "ImportError: initialization failed")
        if not isinstance(sig, ReportsAbandoned):
            raise
        return abandon_reports(sig, outcome.run_dir, helper, getattr(args, "command", None) or "run",
                               len(outcome.stages))
    finally:
        sigs.restore()
    if outcome.status in ("stopped", "aborted"):
        sys.stderr.write(f"ares run: {outcome.status} after {len(outcome.stages)} stage(s); "
                         f"completed stages are kept in {outcome.run_dir}\n")
        return 130
    if outcome.status == "failed":
        sys.stderr.write(f"ares run: failed: {outcome.message}; the {len(outcome.stages)} completed stage(s) are "
                         f"kept in {outcome.run_dir}\n")
        return 1
    if outcome.limit_failures:
        sys.stderr.write(f"ares run: {len(outcome.limit_failures)} limit(s) failed: "
                         f"{'; '.join(outcome.limit_failures)}\n")
        return 4
    if outcome.message:  # done, with something to say (a stage not settled: ares.scan.settling)
        sys.stderr.write(f"ares run: warning: {outcome.message}\n")
    return 0


def finish_reports(run_, args) -> int:
    """``ares resume`` of a run whose stages are complete but whose reports are not: write
    the reports its scan promises, under the same signal handling as ``ares run``."""
    from ares.report import pdf_parts, write_reports
    from ares.rundir.state import owner
    from ares.rundir.record import clean_report_leftovers, set_reports_state

    out = run_.scan.output
    formats = [f for f, on in (("csv", out.csv), ("hdf5", out.hdf5), ("pdf", out.pdf)) if on]
    clean_report_leftovers(run_.dir)
    set_reports_state(run_.dir, "writing", **owner())  # (this process writes them: the run reads as done)
    sigs = Signals().install()
    helper = None
    try:
        helper = pdf_parts.start(run_.dir) if "pdf" in formats else None
        write_reports(run_.dir, formats, helper=helper)
    except ReportsAbandoned as exc:
        return abandon_reports(exc, run_.dir, helper, getattr(args, "command", None) or "resume", len(run_.stages))
    except Exception as exc:  # (a library's own error over the signal, as in ``execute``)
        sig = interruption(exc)
        if not isinstance(sig, ReportsAbandoned):
            raise
        return abandon_reports(sig, run_.dir, helper, getattr(args, "command", None) or "resume", len(run_.stages))
    finally:
        sigs.restore()
    set_reports_state(run_.dir, "complete")
    if sigs.received:
        return finished_anyway(sigs, run_.dir, getattr(args, "command", None) or "resume")
    if not args.quiet:
        print(f"{run_.dir}: the reports of the complete run are written ({', '.join(formats)})")
    return 4 if _limit_failures(run_.dir) else 0


def _limit_failures(run_dir: Path) -> list:
    try:
        return list(json.loads((Path(run_dir) / "scan_results.json").read_text()).get("limit_failures") or [])
    except (OSError, ValueError):
        return []


def _json_summary(outcome, scan, seconds) -> dict:
    from ares.results.registry import limits_verdict
    from ares.rundir.files import _clean

    from ares.labels import FIGURES
    from ares.report.headline import headline

    head = [{"key": k, "name": n, "definition": FIGURES[k][1], **(d or {"value": None})}
            for k, n, d in headline(outcome.scan_results or {})]
    return _clean({"scan": scan.name, "status": outcome.status, "run_dir": str(outcome.run_dir),
                   "seed": outcome.seed, "stages": len(outcome.stages), "seconds": seconds, "headline": head,
                   "scan_results": outcome.scan_results, "limit_failures": outcome.limit_failures,
                   "limits": limits_verdict(outcome.status, len(scan.limits), outcome.limit_failures)})


def run(args) -> int:
    from ares.protocol import load_scan

    scan = load_scan(args.scan, system_path=args.system)
    if args.dry_run:
        dry_run(scan, args.frames, args.seed, out_dir=args.out)
        return 0
    faults = _faults(args.sim_fault)
    argv = ["run", *sys.argv[2:]] if sys.argv[1:2] == ["run"] else None
    if args.repeat == 1:
        return execute(scan, args, seed=args.seed, frames=args.frames, faults=faults, argv=argv, out_dir=args.out)
    rc, i = 0, 0
    base = resolve_out(args.out, scan.name)
    while args.repeat == 0 or i < args.repeat:
        rc = execute(scan, args, seed=args.seed, frames=args.frames, faults=faults, argv=argv,
                     out_dir=base / f"repeat_{i + 1:03d}")
        if rc == 130:
            break
        i += 1
    return rc
