"""Runs a scan job in a QThread and re-emits its events as a Qt signal.

The job's ``run(emit)`` executes in the worker thread; ``emit`` forwards each event
through ``ScanWorker.event`` (a queued connection delivers it in the GUI thread).
Every failure ends as one ``Failed`` event with one sentence: ``AresError`` messages
as they are, anything else as "Unexpected error in the scan engine: ..." (the
traceback goes to the log, never to a dialog).
"""

from __future__ import annotations

import logging

from PySide6.QtCore import QObject, QThread, Signal, Slot

from . import qtfix  # noqa: F401 -- see qtfix.py

from ares.errors import AresError, Interrupted

from .events import Failed, Stopped

log = logging.getLogger(__name__)


def one_sentence(exc: BaseException) -> str:
    if isinstance(exc, AresError):
        text = str(exc).strip() or type(exc).__name__
    else:
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        text = f"Unexpected error in the scan engine: {type(exc).__name__}" + (f" ({detail})" if detail else "")
    text = " ".join(text.split())
    return text if text.endswith((".", "!", "?")) else text + "."


class ScanWorker(QObject):
    event = Signal(object)
    finished = Signal()

    def __init__(self, job) -> None:
        super().__init__()
        self.job = job

    @Slot()
    def run(self) -> None:
        try:
            self.job.run(self.event.emit)
        except Interrupted as exc:
            self.event.emit(Stopped(one_sentence(exc), aborted=True))
        except Exception as exc:  # noqa: BLE001 -- shown as one sentence, logged in full
            log.exception("scan engine failed")
            self.event.emit(Failed(one_sentence(exc)))
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
        self.worker = ScanWorker(job)
        self.worker.moveToThread(self.thread)
        self.thread.started.connect(self.worker.run)
        self.worker.event.connect(self.event)
        self.worker.finished.connect(self.thread.quit)
        self.thread.finished.connect(self._thread_finished)

    def start(self) -> None:
        self.thread.start()

    def _thread_finished(self) -> None:
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
