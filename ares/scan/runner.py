"""The scan runner: stages -> settings -> frames -> accumulators -> results -> run directory.

::

    runner = Runner(scan, out_dir="runs/x", seed=1)       # bench built from the system XML
    runner.add_listener(print)                             # any callable taking an event
    outcome = runner.run()                                 # RunOutcome(status, run_dir, ...)

Control (thread-safe, also from inside a listener): ``pause()``/``resume()`` take effect
between frames; ``stop()`` finishes the current stage and keeps everything; ``abort()``
ends now, discarding only the stage in flight. A hardware fault (``HardwareError``:
timeout, disconnect, short frame) ends the run: the run directory is closed with status
``failed`` and every completed stage, then the error is re-raised with the stage named.
"""

from __future__ import annotations

import logging
import threading
import time
from functools import partial
from pathlib import Path
from typing import Callable


from ares import malloc
from ares.analysis.kernels import recycle
from ares.errors import AresError, HardwareError, InputError, StorageError
from ares.hardware import link_stats
from ares.scan import events as ev
from ares.scan.commit import StageCommitter
from ares.scan.defect_mask import load_declared_mask
from ares.scan.mask_complete import MaskCompletion
from ares.scan.stage_loop import StageLoop
from ares.scan.preflight import check_run
from ares.scan.stage_analysis import views
from ares.rundir.state import is_storage_error, storage_sentence
from ares.rundir.writer import RunWriter
from ares.scan.stages import Stage, estimate_seconds
from ares.scan.eta import Eta, eta_stacks
from ares.scan.settling import FrameNoise
from ares.scan.stages import instruments_used
from ares.scan.suspend import Suspenders
from ares.scan.stage_loop import RunOutcome

log = logging.getLogger(__name__)


RECYCLE_BYTES_PER_PIXEL = 24  # a stack's large arrays: int64 sums 16, a 2-frame batch store 4, a masked shift 4
PIPELINE_MAX_PIXELS = malloc.LARGE_FRAME_PIXELS  # larger frames: a stage is analysed before the next is acquired (memory)


class Runner(MaskCompletion, StageLoop):
    def __init__(self, scan, *, bench=None, out_dir: str | Path | None = None, seed: int | None = None,
                 frames: int | None = None, faults: dict | None = None, argv: list[str] | None = None,
                 listeners: tuple[Callable, ...] = (), resume_from: list[dict] | None = None,
                 defer_reports: bool = False, pipeline: bool = True):
        """``resume_from``: the committed stages of an interrupted run in ``out_dir``; the
        run continues at the first missing stage, appending (``ares resume``).
        ``defer_reports``: a run that ends normally leaves its reports to ``write_reports()``
        (the CLI prints the key figures first: the PDF costs seconds the user need not wait).
        ``pipeline``: a finished stage is analysed and committed in a second thread while the
        next one is acquired (``ares.scan.commit``; same results, files and events) -- for
        frames up to ``PIPELINE_MAX_PIXELS``, beyond which memory matters more."""
        self.pipeline = pipeline
        self.scan = scan
        self.defer_reports = defer_reports
        self._pending_reports = None
        self.resume_from = resume_from
        self.system = scan.system
        self.frames_override = frames
        from ares.results.analyses import check_defect_thresholds

        check_defect_thresholds(scan)  # scans built in code, not loaded from XML, too
        # what --dry-run/validate refuse (the disk: `ares run` before it claims the directory)
        self.stages: list[Stage] = check_run(scan, frames, seed, refuse_disk=False).stages
        if seed is None and self.system.simulator is not None:
            seed = self.system.simulator.seed
        self.seed = seed
        self.faults = faults
        self._bench = bench
        self.out_dir = Path(out_dir) if out_dir else None
        self.argv = argv
        self.listeners: list[Callable] = list(listeners)
        self._pause = threading.Event()
        self._stop = threading.Event()
        self._abort = threading.Event()
        self.state = "idle"

    # -- control ----------------------------------------------------------
    def add_listener(self, fn: Callable) -> None:
        self.listeners.append(fn)

    def pause(self) -> None:
        self._pause.set()

    def resume(self) -> None:
        self._pause.clear()

    def stop(self) -> None:
        """Finish the current stage, keep everything, end."""
        self._stop.set()

    def abort(self) -> None:
        """End now; completed stages are kept, the stage in flight is dropped."""
        self._abort.set()
        self._pause.clear()

    def _cancelled(self) -> bool:
        """True once a stop or abort is requested: instrument waits end on it."""
        return self._stop.is_set() or self._abort.is_set()

    @property
    def paused(self) -> bool:
        return self._pause.is_set()

    def estimate_seconds(self) -> float:
        return estimate_seconds(self.scan, self.stages)

    def _emit(self, event) -> None:
        for fn in list(self.listeners):
            fn(event)

    # -- the run ------------------------------------------------------------
    def run(self) -> RunOutcome:
        if self.state != "idle":
            raise RuntimeError("a Runner runs once; make a new one to repeat")
        self.state = "running"
        own = self._bench is None
        self._own_bench, self._bench_closed = own, False
        self._scratch_dir = None
        bench = self._bench
        writer = None
        completed: list[dict] = []
        try:
            if self.out_dir is not None and self.resume_from is not None:
                writer = RunWriter.reopen(self.out_dir, self.scan, self.resume_from)
                completed.extend(self.resume_from)
            elif self.out_dir is not None:  # before any hardware: a bench that fails to open is recorded too
                writer = RunWriter(self.out_dir, self.scan, seed=self.seed, frames_override=self.frames_override,
                                   argv=self.argv, save_frames=self.scan.output.raw_frames)
                writer.set_total(len(self.stages))
            if own:
                from ares.rig.factory import build_bench

                bench = build_bench(self.system, seed=self.seed, faults=self.faults, uses=instruments_used(
                    self.stages, self.scan))
            if self.system.simulator is not None:  # its fused kernels loaded now, not in a stage's time
                from ares.sim import fused

                fused.warm()
            from ares.analysis.noise import flat
            from ares.analysis.kernels import int_fold
            from ares.analysis.kernels import lowpass
            from ares.analysis.kernels import masked_fold

            int_fold.warm()  # every stack's sums
            masked_fold.warm()  # (the masked stacks after the first dark stage)
            if any(st.scene == "flat" for st in self.stages):  # the EMVA high-pass of a lit stage's
                lowpass.warm()  # analysis: its kernel and gains loaded now, not beside the first
                flat.hp_factors()  # lit stage's frames
            if writer is not None:  # provenance: what the bench says about itself (sim params, chip id)
                writer.meta["bench"] = {k: v for k, v in bench.info.items()
                                        if isinstance(v, (str, int, float, bool, dict, list, type(None)))}
                writer.meta["devices"], writer.link = link_stats.identities(bench), partial(link_stats.counters, bench)
                writer._write_meta()
            shape = tuple(bench.frames.shape)
            want = (self.system.sensor.rows, self.system.sensor.cols)
            if shape != want:
                raise InputError(f"system '{self.system.name}' declares a {want[1]}x{want[0]} array but the frame "
                                 f"source '{bench.frames.name}' delivers {shape[1]}x{shape[0]}")
            outcome = self._run(bench, writer, completed)
            if writer is not None and outcome.stages:
                if self.defer_reports:
                    self._pending_reports = writer
                else:
                    self._reports(writer)
            return outcome
        except AresError as exc:
            msg = str(exc)
            if isinstance(exc, HardwareError) and writer is not None:
                msg = (f"{exc} (during stage {len(completed)}, {len(completed) + 1} of {len(self.stages)}; "
                       f"{len(completed)} completed stage(s) saved in {writer.dir})")
                exc = type(exc)(msg)
            if writer is not None:
                _finish_quietly(writer, "failed", msg)
                if completed and not isinstance(exc, StorageError):  # the tables/report of the saved stages
                    self._reports(writer)
            self.state = "failed"
            self._emit(ev.Failed(msg, str(writer.dir) if writer else None, len(completed)))
            raise exc from None
        except KeyboardInterrupt:  # no signal handler installed (e.g. not the main thread): abort
            if writer is not None:
                _finish_quietly(writer, "aborted", "interrupted")
            self.state = "aborted"
            run_dir = str(writer.dir) if writer else None
            self._emit(ev.Done("aborted", run_dir, len(completed)))
            return RunOutcome("aborted", writer.dir if writer else None, completed, message="interrupted",
                              seed=self.seed)
        except Exception as exc:  # a bug: record it, tell the listeners, keep the traceback
            if is_storage_error(exc):  # (an OS error a library raised outside a storage() block)
                msg = storage_sentence(exc, getattr(exc, "filename", None) or (writer.dir if writer else "the run"))
                if writer is not None:
                    _finish_quietly(writer, "failed", msg)
                self.state = "failed"
                self._emit(ev.Failed(msg, str(writer.dir) if writer else None, len(completed)))
                raise StorageError(msg) from None
            msg = f"internal error: {type(exc).__name__}: {exc}"
            if writer is not None:
                _finish_quietly(writer, "failed", msg)
                if completed:  # a failed run still gets its tables/report for the stages it saved
                    self._reports(writer)
            self.state = "failed"
            self._emit(ev.Failed(msg, str(writer.dir) if writer else None, len(completed)))
            raise
        finally:
            if writer is not None:
                writer.stop_heartbeat()
            if own and bench is not None and not self._bench_closed:
                bench.close()

    def _run(self, bench, writer, completed) -> RunOutcome:
        scan, stages = self.scan, self.stages
        rc = getattr(bench, "recovery_clock", None)  # emulated time for a device's absence (ares.rig.wire)
        clock = {} if rc is None else {"clock": rc.now, "sleep": rc.sleep}
        self._susp = Suspenders(scan.suspend, bench, self._cancelled, **clock) if scan.suspend else None
        self._noise = FrameNoise()  # the run's whole-frame noise, learned from its stacks (ares.scan.settling)
        self._unsettled = []  # stages whose bench did not settle (ares.scan.settling): named in the run's message
        self._late = {}  # sources slower than declared, depths the device contradicts: {what: [(stage, figure)]}
        vw = views(scan)
        max_code = (1 << int(bench.frames.bit_depth)) - 1
        self._frames_total = sum(s.frames_to_grab() for s in stages)
        self._frames_done = 0
        self._t0 = time.monotonic()
        self._est = self.estimate_seconds()
        todo = stages[len(completed):]  # (resuming: the stages still to run)
        self._eta = Eta(self._frames_total, len(todo), self._est,
                        stacks=eta_stacks(scan, todo, bench.frames),
                        stages_by_scene={sc: sum(s.scene == sc for s in todo) for sc in ("dark", "flat")})
        run_dir = str(writer.dir) if writer else None
        self._scratch_dir = run_dir  # kept dark frames beyond memory (ares.scan.kept): on the run's disk
        self._emit(ev.RunStarted(run_dir, len(stages), self._frames_total, self._est))
        cache = None  # last dark StackSet that a matched dark may reuse
        self._mask = load_declared_mask(scan, bench.frames.shape)  # else from the first dark stage
        self._pending = None  # stages committed with a provisional mask a flat will complete (mask_complete)
        applied: dict | None = None
        if completed:  # resuming: the bench, mask and cached dark as the interrupted run left them
            from ares.scan.resume import restore

            cache, applied, mask, note = restore(self, bench, completed, vw, max_code)
            self._mask = mask or self._mask
            if writer is not None and note:
                writer.meta["resumed"][-1].update(note)
                writer._write_meta()
        pixels = bench.frames.shape[0] * bench.frames.shape[1]  # (a 4096x3072 stage in flight: +0.3 GB)
        malloc.for_frames(pixels)
        self._commit = StageCommitter(self._commit_stage, threaded=self.pipeline and pixels <= PIPELINE_MAX_PIXELS)
        # large frames: a finished stage's stack arrays go to the next stage's stacks (two stacks' worth:
        # int64 sums, batch store, masked shift), not new memory (ares.analysis.kernels.recycle)
        recycle.keep(0 if self._commit.threaded or pixels <= PIPELINE_MAX_PIXELS else 2 * RECYCLE_BYTES_PER_PIXEL * pixels)
        try:
            return self._stages(bench, writer, completed, stages, vw, max_code, cache, applied)
        except BaseException:
            self._commit.settle()  # the stages acquired before the error are committed, then it is raised
            raise
        finally:
            recycle.keep(0)

    def write_reports(self, helper=None) -> str:
        """Write the reports a ``defer_reports`` run left pending; returns the report error
        sentence ("" when written or when nothing was pending). ``helper``: a report
        helper process started earlier (``ares.report.pdf_parts.start``)."""
        writer, self._pending_reports = self._pending_reports, None
        if writer is None:
            return ""
        self._reports(writer, helper)
        if writer.meta.get("reports") == "incomplete":  # the disk refused them: exit 5, resume writes them
            raise StorageError(f"{writer.meta['report_error']}; the reports are incomplete (the stages are kept: "
                               f"`ares resume {writer.dir}` writes the reports once the disk allows)")
        return writer.meta.get("report_error", "")

    def _reports(self, writer, helper=None) -> None:
        """The report module's tables (``<output csv/hdf5>``) and PDF (``<output pdf>``),
        written from the run directory alone once the run has ended (done, stopped or failed)."""
        formats = self._report_formats()
        if not formats:
            return
        if writer.meta.get("reports") != "writing":
            writer.set_reports("writing")
        try:
            from ares.report import write_reports

            write_reports(writer.dir, formats, helper=helper)
        except Exception as exc:  # the run's data are complete; a report problem is only noted
            if is_storage_error(exc):  # (the disk: the reports can be written later)
                from ares.rundir.record import clean_report_leftovers

                clean_report_leftovers(writer.dir)
                try:
                    writer.set_reports("incomplete", report_error=storage_sentence(exc, writer.dir))
                except (StorageError, OSError):
                    writer.meta.update(reports="incomplete", report_error=storage_sentence(exc, writer.dir))
                return
            writer.set_reports("failed", report_error=f"{type(exc).__name__}: {exc}")
        else:
            writer.set_reports("complete")

    def _report_formats(self) -> list[str]:
        """The report files the scan promises (``<output csv/hdf5/pdf>``)."""
        out = self.scan.output
        return [f for f, on in (("csv", out.csv), ("hdf5", out.hdf5), ("pdf", out.pdf)) if on]


def _finish_quietly(writer, status: str, message: str) -> None:
    """Record the end of a failed run where the disk still allows it: when it does not
    (full, read-only), run.json keeps 'running' with the pid of a process about to exit,
    which every reader shows as interrupted -- the truth the disk can hold."""
    try:
        writer.finish(status, message)
    except (StorageError, OSError):
        writer.stop_heartbeat()
