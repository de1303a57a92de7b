"""Runs a scan job in a QThread and re-emits its events as a Qt signal.

The job's ``run(emit)`` executes in the worker thread; ``emit`` puts each event in an
``EventPump`` that the GUI thread drains. A frame preview or progress event replaces an
older one of its kind still waiting (never across a stage/result/done event), so a fast
engine cannot bury the window under stale frames -- it always shows the newest.
Every failure ends as one ``Failed`` event with one sentence: ``AresError`` messages
as they are, anything else as "Unexpected error in the scan engine: ..." (the
traceback goes to the log, never to a dialog).
"""

from __future__ import annotations

import logging
import threading

from PySide6.QtCore import QObject, Qt, QThread, Signal, Slot

from . import qtfix  # noqa: F401 -- see qtfix.py

from ares.errors import AresError, Interrupted

from .events import Failed, FramePreview, Progress, Stopped

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


class EventPump(QObject):
    """Thread-safe event queue: ``push`` from any thread, ``event`` emitted in the GUI thread."""

    event = Signal(object)
    _ready = Signal()

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._lock = threading.Lock()
        self._pending: list = []
        self.dropped = 0
        self._ready.connect(self.drain, Qt.ConnectionType.QueuedConnection)  # always later, in the GUI thread

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
            wake = not self._pending
            self._pending.append(ev)
        if wake:
            self._ready.emit()

    @Slot()
    def drain(self) -> None:
        with self._lock:
            items, self._pending = self._pending, []
        for ev in items:
            self.event.emit(ev)


class ScanWorker(QObject):
    finished = Signal()

    def __init__(self, job, pump: EventPump) -> None:
        super().__init__()
        self.job = job
        self.pump = pump

    @Slot()
    def run(self) -> None:
        try:
            self.job.run(self.pump.push)
        except Interrupted as exc:
            self.pump.push(Stopped(one_sentence(exc), aborted=True))
        except Exception as exc:  # noqa: BLE001 -- shown as one sentence, logged in full
            log.exception("scan engine failed")
            self.pump.push(Failed(one_sentence(exc)))
        finally:
            self.finished.emit()


class ScanThread(QObject):
    """Owns a QThread + ScanWorker pair for one run."""

    event = Signal(object)
    finished = Signal()

    def __init__(self, job, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.job = job
        self.thread = QThread()
        self.pump = EventPump(self)
        self.pump.event.connect(self.event)
        self.worker = ScanWorker(job, self.pump)
        self.worker.moveToThread(self.thread)
        self.thread.started.connect(self.worker.run)
        # direct: QThread.quit is thread-safe, and a GUI thread blocked in wait() (window closing)
        # could not deliver a queued call
        self.worker.finished.connect(self.thread.quit, Qt.ConnectionType.DirectConnection)
        self.thread.finished.connect(self._thread_finished)

    def start(self) -> None:
        self.thread.start()

    def _thread_finished(self) -> None:
        self.pump.drain()  # deliver what the worker pushed last, before "finished"
        self.worker.deleteLater()
        self.finished.emit()

    def is_running(self) -> bool:
        return self.thread.isRunning()

    def pause(self) -> None:
        self.job.pause()

    def resume(self) -> None:
        self.job.resume()

    def stop(self) -> None:
        self.job.stop()

    def abort(self) -> None:
        self.job.abort()

    def wait(self, ms: int = 10000) -> bool:
        return self.thread.wait(ms)
