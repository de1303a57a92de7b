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
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Callable

import numpy as np

from ares import malloc
from ares.analysis.kernels import recycle
from ares.errors import AresError, DeviceGone, FrameError, FrameLost, HardwareError, InputError, StorageError
from ares.hardware import link_stats
from ares.hardware.waits import Interrupted
from ares.scan import events as ev
from ares.scan.apply import apply_settings
from ares.scan.commit import StageCommitter
from ares.scan.defect_mask import load_declared_mask, mask_from_dark, scan_thresholds
from ares.scan.mask_complete import MaskCompletion
from ares.scan.preflight import KEEP_FOR_MASK_BYTES, check_run
from ares.results.spectral_readings import photodiode_readings, spectral_readings
from ares.results.registry import StackSet, analyze_stage, check_limits, limits_verdict, scan_level_results, views
from ares.rundir.state import is_storage_error, storage_sentence
from ares.rundir.writer import RunWriter
from ares.rundir.record import RunRecord
from ares.scan.stages import Stage, estimate_seconds
from ares.scan.eta import Eta, eta_stacks
from ares.scan.kept import KeptFrames
from ares.scan.suspend import Suspended, Suspenders

log = logging.getLogger(__name__)


RECYCLE_BYTES_PER_PIXEL = 24  # a stack's large arrays: int64 sums 16, a 2-frame batch store 4, a masked shift 4
PIPELINE_MAX_PIXELS = malloc.LARGE_FRAME_PIXELS  # larger frames: a stage is analysed before the next is acquired (memory)


@dataclass
class RunOutcome:
    status: str  # "done", "stopped", "aborted" or "failed"
    run_dir: Path | None
    stages: list[dict] = field(default_factory=list)
    scan_results: dict = field(default_factory=dict)
    limit_failures: list[str] = field(default_factory=list)
    message: str = ""
    seed: int | None = None


class _Aborted(Exception):
    pass


class Runner(MaskCompletion):
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

                bench = build_bench(self.system, seed=self.seed, faults=self.faults)
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
                msg = (f"{exc} (during stage {len(completed) + 1} of {len(self.stages)}; "
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
        self._susp = Suspenders(scan.suspend, bench, self._cancelled) if scan.suspend else None
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

    def _stages(self, bench, writer, completed, stages, vw, max_code, cache, applied) -> RunOutcome:
        scan, system = self.scan, self.system
        run_dir = str(writer.dir) if writer else None
        status = "done"
        pd_dark = None  # the photodiode's dark readings, kept with the dark stack a later stage reuses
        for st in stages:
            if st.index < len(completed):
                continue
            self._commit.check()
            if self._stop.is_set() or self._abort.is_set():
                status = "aborted" if self._abort.is_set() else "stopped"
                break
            self._emit(ev.StageStarted(st.index, len(stages), st))
            t_start = time.time()
            link0 = link_stats.counters(bench)  # (the snapshot's register reads are the stage's too)
            suspensions, halted, lost, spectral = [], False, [], None
            flat = dark = None  # the last stage's stacks are the committer's now (a 4096x3072 stack: 0.2 GB)
            while True:  # once, or again after a suspension (ares.scan.suspend) or lost frames
                fw = writer.frame_writer(st.index, bench.frames.shape, None) if writer else None
                pos = {}
                try:  # (a device gone while the registers are read is recovered like one gone in a grab)
                    before, dark = bench.registers.snapshot(), None
                    pos["dark"] = _position(bench)
                    if st.dark_source == "grab" and not st.dark_after:  # (dark="after": below)
                        apply_settings(bench, system, st.dark_settings, applied, self._cancelled)
                        applied = st.dark_settings
                        dark = self._grab(bench, st, st.dark_frames, vw, max_code, fw, dark=True)
                        pd_dark = photodiode_readings(bench, system)
                    elif (st.dark_source == "reuse" and cache is not None and cache.masked is None
                          and cache.kept is None and self._mask is not None):
                        # the dark to reuse predates the defect mask and kept no frames: grab it again
                        apply_settings(bench, system, st.dark_settings, applied, self._cancelled)
                        applied = st.dark_settings
                        dark = cache = self._grab(bench, st, st.dark_frames, vw, max_code, fw, dark=True)
                        pd_dark = photodiode_readings(bench, system)
                    elif st.dark_source == "reuse":
                        dark = cache
                    apply_settings(bench, system, st.settings, applied, self._cancelled)
                    applied = dict(st.settings)
                    pos["flat"] = _position(bench)
                    flat = self._grab(bench, st, st.frames, vw, max_code, fw, dark=False)
                    spectral = spectral_readings(bench, system)
                    if st.dark_after:  # the bright->dark cycle the lag analysis reads
                        pos["dark"] = _position(bench)
                        apply_settings(bench, system, st.dark_settings, applied, self._cancelled)
                        applied = st.dark_settings
                        dark = self._grab(bench, st, st.dark_frames, vw, max_code, fw, dark=True)
                        pd_dark = photodiode_readings(bench, system)
                    pos["end"], after = _position(bench), bench.registers.snapshot()
                except FrameLost as exc:  # dropped/corrupt/short frames: acquire the stage again, or fail
                    if fw is not None:
                        fw.close(keep=False)
                    lost.append({"kind": exc.kind, "count": exc.count, "message": str(exc)})
                    if self.scan.on_loss != "regrab" or len(lost) > self.scan.max_regrabs:
                        if self.scan.on_loss == "regrab":
                            raise FrameLost(f"{exc} -- still losing frames after {self.scan.max_regrabs} re-grab(s) "
                                            "(<frames max_regrabs>)", exc.kind, exc.count) from None
                        raise
                    self._emit(ev.Regrab(st.index, str(exc)))
                    applied = {}  # start the stage from a known state
                    continue
                except (Suspended, DeviceGone) as exc:  # suspenders: drop the stage's frames, wait, acquire again
                    if fw is not None:
                        fw.close(keep=False)
                    if not (self._susp is not None and self._susp.handles(exc)):
                        raise
                    self._emit(ev.Paused(st.index))
                    try:
                        suspensions.append(self._susp.wait_out(exc, st.name, len(suspensions)))
                    except Interrupted:
                        status, halted = ("aborted" if self._abort.is_set() else "stopped"), True
                        break
                    if isinstance(exc, DeviceGone):
                        applied = {}  # it may have lost its settings: apply every one again
                    self._emit(ev.Resumed(st.index))
                    continue
                except (_Aborted, Interrupted):  # aborted mid-stage, or stopped while an instrument settled
                    if fw is not None:
                        fw.close(keep=False)
                    status, halted = ("aborted" if self._abort.is_set() else "stopped"), True
                    break
                except BaseException:
                    if fw is not None:
                        fw.close(keep=False)
                    raise
                break
            if halted:
                break
            if fw is not None:
                fw.close(keep=True)
            if not self._commit.threaded:  # large frames: the stage is analysed now, the source's caches wait
                release = getattr(bench.frames, "release", None)
                if release is not None:
                    release()
            if st.scene == "dark":
                cache = flat
            elif st.dark_source == "grab":
                cache = dark
            if not self._commit.threaded:  # the pool holds no arrays through the mask and the analysis (the
                recycle.clear()  # previous dark, just dropped, among them): the run's peak stays the same
            new_mask = self._mask is None and st.scene == "dark" and st.settings.get("reg:test_mode", 0) == 0
            if new_mask:  # before the next stage's frames: they are masked as they arrive
                t_mask = time.monotonic()
                self._mask = mask_from_dark(flat, st.name, st.settings.get("exposure"), scan_thresholds(scan))
                flat.series_pixels = self._mask.rts_candidates  # kept with the mask from its frames
                later_flat = any(s.scene == "flat" for s in stages if s.index > st.index)
                if later_flat:  # a flat will complete the mask: this stage's frames are kept till then
                    self._start_pending()
                flat.apply_mask(self._mask.mask, close=not later_flat)  # this stage too, from its kept frames
                self._eta.one_off(time.monotonic() - t_mask)
            self._eta.stage_finished(time.monotonic() - self._t0, st.scene)
            extra = {"dark_after": True} if st.dark_after else {}  # its matched dark followed the flat
            if spectral is not None:  # the monochromator's wavelength and the photodiode, lit and dark
                extra["spectral"] = dict(spectral, pd_dark=pd_dark if dark is not None else None)
            if pos.get("end") is not None:
                extra["bench_position"] = pos  # where the frame stream stood (ares resume)
            if suspensions:
                extra["suspensions"] = suspensions
            if lost:
                extra["frames_lost"] = lost
            if link0:  # what the stage did on each link, retries and recoveries included
                extra["link"] = link_stats.delta(link0, link_stats.counters(bench))
            self._stage_ended((st, flat, dark, extra, new_mask, before, after, t_start, writer, completed))
            if self._commit.cpu_seconds is not None:  # the latest stage's analysis and write: the run
                self._eta.end_work(self._commit.cpu_seconds)  # waits for the last stage's after its frames
        else:
            if self._stop.is_set():
                status = "done"  # stop during the last stage: the scan is complete anyway
            self._complete_mask()  # no flat completed the mask: the brightest one it has does
        self._commit.wait()
        cache = flat = dark = None  # the stacks' sums are committed: free them before the scan-level analyses
        if self._own_bench:  # no more frames: the devices close now (the light goes off, the simulator's maps go)
            self._bench_closed = True
            try:
                bench.close()
            except Exception as exc:  # the run's data are complete: a device that will not close is noted
                log.warning("closing the bench: %s", exc)
        self._emit(ev.Ending(status, len(completed)))
        scan_results, fails = {}, []
        message = ""
        if completed:
            record = RunRecord(writer.dir if writer else None, writer.meta if writer else {}, scan, completed)
            scan_results = scan_level_results(record)
            broken = {k: r.get("note", "") for k, r in scan_results.items()
                      if isinstance(r, dict) and r.get("status") == "error"}
            if broken and status == "done":  # the stages are kept; the run did not deliver its results
                status = "failed"
                message = "scan-level analysis failed: " + "; ".join(f"{k}: {v}" for k, v in broken.items())
            if status == "done":
                fails = check_limits(scan, scan_results)
        if writer:  # the reports to come are part of the run: "done" reads so only once they are written
            writer.finish(status, message or "; ".join(fails), scan_results, fails,
                          reports="writing" if completed and self._report_formats() else None,
                          limits=limits_verdict(status, len(scan.limits), fails))
        self.state = status
        self._emit(ev.Done(status, run_dir, len(completed), scan_results, tuple(fails)))
        return RunOutcome(status, writer.dir if writer else None, completed, scan_results, fails, message=message,
                          seed=self.seed)

    def _commit_stage(self, mask, st: Stage, flat, dark, extra: dict, new_mask: bool, before: dict, after: dict,
                      t_start: float, writer, completed: list) -> None:
        """Analyse a stage whose frames are all in, write it to the run directory, tell the
        listeners (``ares.scan.commit``: beside the next stage's acquisition). ``mask``: the
        defect mask its stacks were masked with (the runner's may have moved on since)."""
        result, arrays = self._analyze(mask, st, flat, dark, extra, new_mask, completed)
        timing = {"started": t_start, "finished": time.time(), "seconds": time.time() - t_start}
        if writer:
            writer.add_stage(result, arrays, before, after, timing)
        completed.append(dict(result, registers_before=before, registers_after=after, timing=timing))
        self._emit(ev.StageFinished(st.index, len(self.stages), st, result, arrays))

    def _recommit_stage(self, mask, st: Stage, flat, dark, extra: dict, new_mask: bool, before: dict, after: dict,
                        t_start: float, writer, completed: list) -> None:
        """A committed stage analysed again with the mask a flat completed since, rewritten
        in place (its timing is its acquisition's), with ``StageUpdated`` (mask_complete)."""
        k = next(i for i, c in enumerate(completed) if c["index"] == st.index)
        result, arrays = self._analyze(mask, st, flat, dark, extra, new_mask, completed[:k])
        timing = completed[k]["timing"]
        if writer:
            writer.replace_stage(result, arrays, before, after, timing)
        completed[k] = dict(result, registers_before=before, registers_after=after, timing=timing)
        self._emit(ev.StageUpdated(st.index, len(self.stages), st, result, arrays))

    def _analyze(self, mask, st: Stage, flat, dark, extra: dict, new_mask: bool, completed: list) -> tuple[dict, dict]:
        result, arrays = analyze_stage(st, flat, dark)
        for stack in (flat, dark):
            if stack is not None:
                stack.drop_maps()
        result.update(extra)
        arrays.update(link_stats.arrays(extra.get("link")))
        if mask is not None:
            result["defect_mask"] = mask.summary()
            if new_mask or not completed:  # the mask itself, once, with the stage it came from
                arrays["defect_mask"] = mask.mask.astype(np.uint8)
        return result, arrays

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

    def _grab(self, bench, st: Stage, n: int, vw, max_code, fw, dark: bool) -> StackSet:
        src = bench.frames
        shape = tuple(src.shape)
        mask = getattr(self, "_mask", None)
        pending = getattr(self, "_pending", None) is not None  # a provisional mask: keep the frames too
        ss = StackSet(shape, vw, max_code, histograms=bool({"adc_linearity", "photon_counting"} & set(self.scan.analyses)),
                      mask=mask.mask if mask is not None else None)
        if pending or (mask is None and not dark and st.scene == "dark"):
            # the stage a defect mask will be built from, or a stage to mask again when a flat
            # completes it (ares.scan.mask_complete): keep its frames
            ss.kept = KeptFrames(max(KEEP_FOR_MASK_BYTES - self._pending_in_memory(), 0), self._scratch_dir)
        self._eta.stage_started(time.monotonic() - self._t0,  # waiting for a first frame is stage work
                                "dark" if dark or st.scene == "dark" else "flat", st.scene)
        it = iter(src.grab(n))
        k = 0
        try:
            while True:
                if self._pause.is_set():
                    self._emit(ev.Paused(st.index))
                    while self._pause.is_set() and not self._abort.is_set():
                        time.sleep(0.02)
                    self._emit(ev.Resumed(st.index))
                if self._abort.is_set():
                    raise _Aborted
                if self._susp is not None:
                    self._susp.check(st.dark_settings if dark else st.settings, force=k == 0)
                try:
                    frame = next(it)  # run the source to its end (it may count frames after a yield)
                except StopIteration:
                    break
                if k >= n:
                    raise FrameError(f"{src.name}: delivered more than the {n} frames asked for")
                data = frame.data
                if data.shape != shape:
                    raise FrameError(f"{src.name}: short frame {k} (shape {data.shape[1] if data.ndim > 1 else '?'}x"
                                     f"{data.shape[0]}, expected {shape[1]}x{shape[0]})")
                ss.add(data)
                ss.note_frame(frame)
                if fw is not None:
                    fw.add(data, dark=dark)
                self._frames_done += 1
                elapsed = time.monotonic() - self._t0
                fps = self._frames_done / elapsed if elapsed > 0 else 0.0
                self._eta.frame(elapsed, None if getattr(src, "exposure_paced", True)
                                else getattr(src, "compute_seconds", None))
                remaining = self._eta.remaining(elapsed)
                self._emit(ev.FramePreview(st.index, k, n, data, dark))
                self._emit(ev.Progress(st.index, len(self.stages), self._frames_done, self._frames_total, fps,
                                       remaining))
                k += 1
        finally:
            close = getattr(it, "close", None)
            if close:
                close()
        if k < n:
            raise FrameError(f"{src.name}: delivered only {k} of {n} frames")
        ss.compact()  # a 4096x3072 stack's batch store and scratch are ~1 GB; its sums are what stays
        return ss


def _position(bench) -> dict | None:
    """The frame source's stream position where it can tell one (the simulator), else None."""
    fn = getattr(bench.frames, "position", None)
    return fn() if callable(fn) else None


def _finish_quietly(writer, status: str, message: str) -> None:
    """Record the end of a failed run where the disk still allows it: when it does not
    (full, read-only), run.json keeps 'running' with the pid of a process about to exit,
    which every reader shows as interrupted -- the truth the disk can hold."""
    try:
        writer.finish(status, message)
    except (StorageError, OSError):
        writer.stop_heartbeat()
