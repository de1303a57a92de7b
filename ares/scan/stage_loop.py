"""The runner's stage loop: for each stage, settings applied, frames grabbed into the stacks of
every view (masked as they arrive once a defect mask exists), the stage analysed and committed
beside the next stage's acquisition, and the events emitted; suspenders, pause and stop
honoured between frames. A mixin of ``ares.scan.runner.Runner`` (its state is the runner's)."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
import numpy as np
from ares.analysis.kernels import recycle
from ares.errors import DeviceGone, FrameError, FrameLost
from ares.hardware import link_stats
from ares.hardware.waits import Interrupted
from ares.scan import events as ev
from ares.scan.apply import apply_settings
from ares.scan.defect_mask import bound_incomplete, mask_from_dark, scan_thresholds
from ares.scan.preflight import KEEP_FOR_MASK_BYTES
from ares.results.spectral_readings import photodiode_readings, spectral_readings
from ares.results.registry import check_limits, limits_verdict, scan_level_results
from ares.scan.stage_analysis import RAMP_GROUPS, StackSet, analyze_stage
from ares.rundir.record import RunRecord
from ares.scan.stages import Stage
from ares.scan.kept import KeptFrames
from ares.scan.readback import light_reading, setpoints
from ares.scan.settling import FrameStats
from ares.scan.suspend import Suspended

TRANSIENT = ("timeout", "stall", "short")  # frames lost to a fault that a re-grab outlives
log = logging.getLogger("ares.scan.runner")  # (the runner's log: the loop is part of it)


class StageLoop:
    """``Runner``'s stage loop (``_stages``) and what each stage does (grab, analyse, commit)."""

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
            reacquired, settling = [], {}  # stacks acquired again (a trend or a step), what each change waited
            # a dark stage after a flat in a lag scan: the decay of image lag in its first frames is the
            # measurement -- the declared waits only, and its stack is not checked for a trend
            lag_dark = ("lag" in scan.analyses and st.scene == "dark" and st.index > 0
                        and stages[st.index - 1].scene == "flat")
            flat = dark = lit = None  # the last stage's stacks are the committer's now (a 4096x3072 stack: 0.2 GB)
            while True:  # once, or again after a suspension (ares.scan.suspend) or lost frames
                fw = writer.frame_writer(st.index, bench.frames.shape, None) if writer else None
                pos = {}
                try:  # (a device gone while the registers are read is recovered like one gone in a grab)
                    before, dark = bench.registers.snapshot(), None
                    pos["dark"] = _position(bench)
                    if st.dark_source == "grab" and not st.dark_after:  # (dark="after": below)
                        _note(settling, "dark", apply_settings(bench, system, st.dark_settings, applied,
                                                               self._cancelled, noise=self._noise,
                                                               abort=self._abort.is_set))
                        applied = st.dark_settings
                        dark = self._grab(bench, st, st.dark_frames, vw, max_code, fw, dark=True)
                        pd_dark = photodiode_readings(bench, system)
                    elif (st.dark_source == "reuse" and cache is not None and cache.masked is None
                          and cache.kept is None and self._mask is not None):
                        # the dark to reuse predates the defect mask and kept no frames: grab it again
                        _note(settling, "dark", apply_settings(bench, system, st.dark_settings, applied,
                                                               self._cancelled, noise=self._noise,
                                                               abort=self._abort.is_set))
                        applied = st.dark_settings
                        dark = cache = self._grab(bench, st, st.dark_frames, vw, max_code, fw, dark=True)
                        pd_dark = photodiode_readings(bench, system)
                    elif st.dark_source == "reuse":
                        dark = cache
                    _note(settling, "flat", apply_settings(bench, system, st.settings, applied, self._cancelled,
                                                          evidence=not lag_dark, noise=self._noise,
                                                          abort=self._abort.is_set))
                    applied = dict(st.settings)
                    pos["flat"] = _position(bench)
                    flat = self._grab(bench, st, st.frames, vw, max_code, fw, dark=False)
                    spectral = spectral_readings(bench, system)
                    lit = light_reading(bench) if st.dark_after else None  # (its dark turns the light off)
                    if st.dark_after:  # the bright->dark cycle the lag analysis reads
                        pos["dark"] = _position(bench)
                        _note(settling, "dark", apply_settings(bench, system, st.dark_settings, applied,
                                                               self._cancelled, evidence=False))
                        applied = st.dark_settings
                        dark = self._grab(bench, st, st.dark_frames, vw, max_code, fw, dark=True)
                        pd_dark = photodiode_readings(bench, system)
                    pos["end"], after = _position(bench), bench.registers.snapshot()
                except FrameLost as exc:  # dropped/corrupt/short frames: acquire the stage again, or fail
                    if fw is not None:
                        fw.close(keep=False)
                    lost.append({"kind": exc.kind, "count": exc.count, "message": str(exc)})
                    # a transient fault (a late frame, a stalled endpoint) under <suspend device>: re-grab too
                    transient = exc.kind in TRANSIENT and self._susp is not None and self._susp.handles_devices
                    if (self.scan.on_loss != "regrab" and not transient) or len(lost) > self.scan.max_regrabs:
                        if self.scan.on_loss == "regrab" or transient:
                            raise FrameLost(f"{exc} -- still losing frames after {self.scan.max_regrabs} re-grab(s) "
                                            "(<frames max_regrabs>)", exc.kind, exc.count) from None
                        raise
                    self._emit(ev.Regrab(st.index, str(exc)))
                    self._link_health(bench, st.index)
                    applied = {}  # start the stage from a known state
                    continue
                except (Suspended, DeviceGone) as exc:  # suspenders: drop the stage's frames, wait, acquire again
                    if fw is not None:
                        fw.close(keep=False)
                    if not (self._susp is not None and self._susp.handles(exc)):
                        raise
                    self._emit(ev.Paused(st.index, str(exc)))
                    self._link_health(bench, st.index)
                    try:
                        suspensions.append(self._susp.wait_out(exc, st.name, len(suspensions)))
                    except Interrupted:
                        status, halted = ("aborted" if self._abort.is_set() else "stopped"), True
                        break
                    if isinstance(exc, DeviceGone):
                        applied = {}  # it may have lost its settings: apply every one again
                    self._emit(ev.Resumed(st.index, suspensions[-1].get("seconds"), str(exc)))
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
                unsteady = (None if lag_dark or getattr(bench.frames, "recorded", False)  # (a replay: as recorded)
                            else _unsteady(st, flat, dark, system, self._noise))
                if unsteady and self._susp is not None and len(reacquired) < system.timing.settle.reacquire:
                    if fw is not None:  # under <suspend>: a stack that trends or steps is acquired again
                        fw.close(keep=False)
                    reacquired.append(unsteady)
                    self._emit(ev.Regrab(st.index, "not settled: " + _say(unsteady)))
                    applied = {}  # every setting again, and the bench settled again by its frames
                    continue
                settling.update(_verdict(settling, unsteady, reacquired))
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
            if pos.get("end") is not None or after:  # each set quantity: set point, readback, tolerance
                extra["setpoints"] = setpoints(bench, system, st.settings, after or {}, lit)
                off = [k for k, v in extra["setpoints"].items() if v.get("ok") is False]
                if off:
                    log.warning("stage %d '%s': readback outside its tolerance for %s", st.index, st.name,
                                ", ".join(off))
            if settling:  # what each change waited and discarded, and why; a stack that trends or steps
                extra["settling"] = settling
                _late(self._late, st.index, settling)
                if settling.get("unsettled"):
                    self._unsettled.append(f"stage {st.index} '{st.name}': {settling['unsettled']}")
                    log.warning("stage %d '%s' is not settled: %s", st.index, st.name, settling["unsettled"])
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
        if self._unsettled:  # said on every surface: run.json's message, the outcome, the log
            message = "; ".join(m for m in (message, "not settled: " + "; ".join(self._unsettled)) if m)
        if self._late:  # the bench slower or deeper than its system XML declares: the host waited or discarded
            message = "; ".join(m for m in (message, late_text(self._late)) if m)
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
            full = result["views"].get("full", {})
            if "components_masked" in full:
                full["components_masked"] = bound_incomplete(full["components_masked"], mask)
            if new_mask or not completed:  # the mask itself, once, with the stage it came from
                arrays["defect_mask"] = mask.mask.astype(np.uint8)
        return result, arrays


    def _link_health(self, bench, index: int) -> None:
        """``LinkHealth`` when the links' trouble counters changed since the last one."""
        now = link_stats.trouble(link_stats.counters(bench))
        if now != getattr(self, "_health", {}):
            self._health = now
            self._emit(ev.LinkHealth(index, now))

    def _grab(self, bench, st: Stage, n: int, vw, max_code, fw, dark: bool) -> StackSet:
        src = bench.frames
        shape = tuple(src.shape)
        mask = getattr(self, "_mask", None)
        pending = getattr(self, "_pending", None) is not None  # a provisional mask: keep the frames too
        ramp = not dark and "adc_linearity" in self.scan.analyses and st.settings.get("reg:test_mode") == 2
        ss = StackSet(shape, vw, max_code, histograms=bool({"adc_linearity", "photon_counting"} & set(self.scan.analyses)),
                      mask=mask.mask if mask is not None else None, groups=RAMP_GROUPS if ramp else 0)
        if pending or (mask is None and not dark and st.scene == "dark"):
            # the stage a defect mask will be built from, or a stage to mask again when a flat
            # completes it (ares.scan.mask_complete): keep its frames
            ss.kept = KeptFrames(max(KEEP_FOR_MASK_BYTES - self._pending_in_memory(), 0), self._scratch_dir)
        self._eta.stage_started(time.monotonic() - self._t0,  # waiting for a first frame is stage work
                                "dark" if dark or st.scene == "dark" else "flat", st.scene)
        ss.frame_stats = []
        it = iter(src.grab(n))
        k = 0
        try:
            while True:
                if self._pause.is_set():
                    self._emit(ev.Paused(st.index, "paused by the user"))
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
                ss.frame_stats.append(FrameStats.of(data))  # the stack's steadiness (ares.scan.settling)
                if fw is not None:
                    fw.add(data, dark=dark)
                self._frames_done += 1
                elapsed = time.monotonic() - self._t0
                fps = self._frames_done / elapsed if elapsed > 0 else 0.0
                self._eta.frame(elapsed, None if getattr(src, "exposure_paced", True)
                                else getattr(src, "compute_seconds", None))
                remaining = self._eta.remaining(elapsed)
                self._link_health(bench, st.index)
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


def _late(late: dict, index: int, settling: dict) -> None:
    """Collect what a stage's settling records show slower or deeper than declared: a source
    the host had to wait for beyond the declared waits (``source_settled``), a device holding
    more frames from before a change than ``frames_in_flight`` (``in_flight.depth_exceeded``)."""
    for rec in settling.values():
        if not isinstance(rec, dict):
            continue
        for q, s in (rec.get("sources") or {}).items():
            if (s.get("waited_s") or 0) > 0:
                late.setdefault(q, []).append((index, float(s["waited_s"])))
        dx = (rec.get("in_flight") or {}).get("depth_exceeded")
        if dx:
            late.setdefault("frames in flight", []).append((index, dx))


def late_text(late: dict) -> str:
    """One sentence for the run's message from ``_late``'s collection."""
    parts = []
    for what, hits in late.items():
        stages = ", ".join(str(i) for i, _ in hits[:8]) + (" ..." if len(hits) > 8 else "")
        if what == "frames in flight":
            seen, decl = max(d["seen"] for _, d in hits), hits[0][1]["declared"]
            parts.append(f"the device held up to {seen} frames from before a change where the system declares "
                         f"<timing frames_in_flight=\"{decl}\"> (stages {stages}): declare {seen}")
        else:
            parts.append(f"{what} settled slower than declared (stages {stages}; waited up to "
                         f"{max(w for _, w in hits):.3g} s beyond the declared waits): lengthen its <after settle_s>")
    log.warning("bench slower than declared: %s", "; ".join(parts))
    return "bench slower than declared: " + "; ".join(parts)


def _note(settling: dict, which: str, rec: dict | None) -> None:
    """Keep a change's settling record (the latest of an acquisition repeated)."""
    if rec is not None:
        settling[which] = rec


def _unsteady(st: Stage, flat, dark, system, noise) -> dict | None:
    """The stacks that trend or step (``ares.scan.settling.stack_verdict``): {"flat"/"dark": what}.
    A dark grabbed after its flat is not checked (the decay of image lag is its measurement),
    nor a dark reused from an earlier stage."""
    from ares.scan.settling import stack_verdict

    cfg = system.timing.settle  # (checked whichever way the bench settled: by="time" too)
    out = {}
    for which, ss in (("flat", flat), ("dark", dark if st.dark_source == "grab" and not st.dark_after else None)):
        stats = getattr(ss, "frame_stats", None)
        v = stack_verdict(stats, cfg.k, cfg.rtol, noise) if stats else None
        if v is not None:
            out[which] = v
        elif stats:
            noise.learn(stats)  # a steady stack teaches the run its whole-frame noise
    return out or None


def _say(unsteady: dict) -> str:
    return "; ".join(f"the {w} stack {v['kind']}s by {v['change_dn']:+.3g} DN (tolerance {v['tolerance_dn']:.3g} DN)"
                     for w, v in unsteady.items())


def _verdict(settling: dict, unsteady: dict | None, reacquired: list) -> dict:
    """The stage's settling verdict: ``unsettled`` names why when a change did not settle
    within its cap or the stack kept trending or stepping."""
    out = {"stack": unsteady or "steady"}
    if reacquired:
        out["reacquired"] = reacquired
    why = [f"{w}: {r['why']}" for w, r in settling.items() if isinstance(r, dict) and r.get("settled") is False]
    if unsteady:
        why.append(_say(unsteady))
    if why:
        out["unsettled"] = "; ".join(why)
    return out


def _position(bench) -> dict | None:
    """The frame source's stream position where it can tell one (the simulator), else None."""
    fn = getattr(bench.frames, "position", None)
    return fn() if callable(fn) else None
