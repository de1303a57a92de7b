"""Runs a scan job in a plain Python thread; the GUI thread polls its events.

The job's ``run(emit)`` executes in a ``threading.Thread`` that never calls Qt: ``emit``
only appends to an ``EventPump`` under a lock, and a ``QTimer`` in the GUI thread drains
it. Garbage collection is moved to the GUI thread while a scan thread runs: the
cyclic collector runs in whichever thread happens to allocate, and when the scan thread
(building report figures, say) collected unreachable Qt wrappers it destroyed Qt objects
outside their thread and the process deadlocked on the GIL (seen with PySide6 6.9-6.11
under load). Automatic collection is suspended for the run and the poll timer collects
by the same generation thresholds. A frame preview or progress
event replaces an older one of its kind still waiting (never across a
stage/result/done event), so a fast engine cannot bury the window under stale frames --
it always shows the newest; and previews and progress are drawn at most every
``PREVIEW_INTERVAL_S`` / ``PROGRESS_INTERVAL_S`` (time-decimated: one that comes too soon waits for a later poll,
or is dropped when a newer stage event follows it), so drawing never competes with
acquisition. Every failure ends as one ``Failed`` event with one
sentence: ``AresError`` messages as they are, anything else as "Unexpected error in the
scan engine: ..." (the traceback goes to the log, never to a dialog).
"""

from __future__ import annotations

import gc
import logging
import threading
import time

from PySide6.QtCore import QObject, QTimer, Signal, Slot

from ares.errors import AresError, Interrupted

from ares.gui.events import Failed, FramePreview, Progress, Stopped

log = logging.getLogger(__name__)


def one_sentence(exc: BaseException) -> str:
    if isinstance(exc, AresError):
        text = str(exc).strip() or type(exc).__name__
    else:
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        text = f"Unexpected error in the scan engine: {type(exc).__name__}" + (f" ({detail})" if detail else "")
    text = " ".join(text.split())
    return text if text.endswith((".", "!", "?")) else text + "."


COALESCE = (FramePreview, Progress)
PREVIEW_INTERVAL_S = 0.4
PROGRESS_INTERVAL_S = 0.1  # a few labels: cheap to draw, and a stage of make run lasts ~0.15 s


class EventPump(QObject):
    """Thread-safe event queue: ``push`` from any thread (no Qt call), ``drain`` in the
    GUI thread emits ``event`` for each waiting event."""

    event = Signal(object)

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._lock = threading.Lock()
        self._pending: list = []
        self.dropped = 0
        self.interval_s = PREVIEW_INTERVAL_S  # previews ...
        self.progress_interval_s = PROGRESS_INTERVAL_S  # ... and progress, each at most this often
        self.clock = time.monotonic
        self._last: dict[type, float] = {}  # when a preview / progress event was last delivered

    def push(self, ev) -> None:
        with self._lock:
            if isinstance(ev, COALESCE):
                for k in range(len(self._pending) - 1, -1, -1):
                    old = self._pending[k]
                    if type(old) is type(ev):
                        del self._pending[k]
                        self.dropped += 1
                        break
                    if not isinstance(old, COALESCE):
                        break
            self._pending.append(ev)

    @Slot()
    def drain(self) -> None:
        now = self.clock()
        with self._lock:
            items, self._pending = self._pending, []
        newest = {type(ev): k for k, ev in enumerate(items) if isinstance(ev, COALESCE)}
        out, held = [], []
        for k, ev in enumerate(items):
            kind = type(ev)
            limit = self.interval_s if kind is FramePreview else self.progress_interval_s
            if isinstance(ev, COALESCE) and now - self._last.get(kind, -float("inf")) < limit:
                if k == newest[kind] and all(isinstance(x, COALESCE) for x in items[k + 1:]):
                    held.append(ev)  # the newest of its kind, nothing newer behind it: a later poll
                elif kind is FramePreview:
                    self.dropped += 1
                continue
            if isinstance(ev, COALESCE):
                self._last[kind] = now
            out.append(ev)
        if held:
            with self._lock:
                for ev in reversed(held):  # older than anything pushed meanwhile: in front, unless superseded
                    if not any(type(x) is type(ev) for x in self._pending):
                        self._pending.insert(0, ev)
                    elif type(ev) is FramePreview:
                        self.dropped += 1
        for ev in out:
            self.event.emit(ev)


def run_job(job, push) -> None:
    """The scan thread's body: run the job, turn every failure into one event."""
    try:
        job.run(push)
    except Interrupted as exc:
        push(Stopped(one_sentence(exc), aborted=True))
    except Exception as exc:  # noqa: BLE001 -- shown as one sentence, logged in full
        log.exception("scan engine failed")
        push(Failed(one_sentence(exc)))


class _GuiThreadGc:
    """Suspend automatic garbage collection while any scan thread runs; ``collect()``
    (called from the GUI thread) collects by the interpreter's own thresholds."""

    active = 0
    was_enabled = True

    @classmethod
    def acquire(cls) -> None:
        if cls.active == 0:
            cls.was_enabled = gc.isenabled()
            gc.disable()
        cls.active += 1

    @classmethod
    def release(cls) -> None:
        cls.active -= 1
        if cls.active == 0 and cls.was_enabled:
            gc.enable()

    @staticmethod
    def collect() -> None:
        counts, limits = gc.get_count(), gc.get_threshold()
        gen = max((g for g in range(3) if counts[g] > limits[g]), default=-1)
        if gen >= 0:
            gc.collect(gen)


class StatsExecutor:
    """One thread for the window's statistics panels (``SessionModel.executor``), offered
    only while a scan thread runs: automatic garbage collection is then held in the
    window's thread (see the module), so this thread's work never finalizes Qt objects."""

    def __init__(self) -> None:
        from concurrent.futures import ThreadPoolExecutor

        self._pool = ThreadPoolExecutor(1, thread_name_prefix="ares-gui-stats")

    @staticmethod
    def available() -> bool:
        return _GuiThreadGc.active > 0

    def submit(self, fn):
        return self._pool.submit(fn)

    def shutdown(self) -> None:
        self._pool.shutdown()


class ScanThread(QObject):
    """One run: the job in a Python thread, its events drained by a GUI-thread timer."""

    event = Signal(object)
    finished = Signal()
    POLL_MS = 25

    def __init__(self, job, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.job = job
        self.pump = EventPump(self)
        self.pump.event.connect(self.event)
        self.thread = threading.Thread(target=run_job, args=(job, self.pump.push),
                                       name="ares-scan", daemon=True)
        self.timer = QTimer(self)
        self.timer.setInterval(self.POLL_MS)
        self.timer.timeout.connect(self._poll)
        self._done = False
        self.settle = lambda: None  # called in the window's thread before the run's end is told

    def start(self) -> None:
        _GuiThreadGc.acquire()
        self.thread.start()
        self.timer.start()

    def _poll(self) -> None:
        alive = self.thread.is_alive()
        self.pump.drain()
        _GuiThreadGc.collect()
        if not alive and not self._done:  # everything the job pushed has been delivered
            self.settle()
            self._end()
            self.finished.emit()

    def _end(self) -> None:
        self._done = True
        self.timer.stop()
        _GuiThreadGc.release()

    def is_running(self) -> bool:
        return self.thread.is_alive()

    def pause(self) -> None:
        self.job.pause()

    def resume(self) -> None:
        self.job.resume()

    def stop(self) -> None:
        self.job.stop()

    def abort(self) -> None:
        self.job.abort()

    def wait(self, ms: int = 10000) -> bool:
        if self.thread.ident is not None:
            self.thread.join(ms / 1000)
        if self.thread.ident is not None and not self.thread.is_alive() and not self._done:
            self.pump.drain()  # e.g. the window is closing: no poll will come to end the run
            self.settle()
            self._end()
            self.finished.emit()
        return not self.thread.is_alive()
