"""A run's state as its directory tells it, and the errors of the disk it is written to.

Imports nothing of the project but ``ares.safefile`` (the storage errors' sentences), so that the writer (``ares.rundir.writer``), the report
(``ares.report.source``) and the GUI read a run's state the same way.

- ``run.json`` records who runs it: ``pid``, ``host``, ``heartbeat`` (seconds since the
  epoch, refreshed at least every ``HEARTBEAT_S`` while the process lives).
- ``effective_status(meta)``: a ``running`` run whose process is gone (same host, pid not
  alive) or whose heartbeat is older than ``STALE_S`` reads as ``interrupted`` -- a run
  killed by SIGKILL or a power cut never stays ``running`` forever.
- ``reports`` in ``run.json``: ``writing`` while the reports (tables, ``report.h5``, PDF) a
  finished run promises are written, ``complete`` once every one is renamed into place,
  ``incomplete`` when a signal abandoned them. A ``done`` run whose reports are
  ``incomplete`` (or still ``writing`` with its process gone) reads as
  ``reports incomplete``: ``ares resume`` or ``ares report`` writes them.
- ``storage_sentence(exc, path)``: disk full, read-only, quota, permission -> one sentence
  naming the path (never a traceback, never a half-truth about what was saved).
"""

from __future__ import annotations

import os
import socket
import threading
import time

# the storage errors' sentences are every command's (``ares.safefile``: the output guard)
from ares.safefile import STORAGE_ERRNOS, is_storage_error, os_errno, storage_sentence  # noqa: F401

HEARTBEAT_S = 5.0
STALE_S = 120.0

REPORTS_INCOMPLETE = "reports incomplete"


def owner() -> dict:
    return {"pid": os.getpid(), "host": socket.gethostname(), "heartbeat": time.time()}


def pid_alive(pid: int) -> bool:
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    except (OverflowError, ValueError, TypeError):
        return False
    return True


def _process_gone(meta: dict) -> bool:
    pid = meta.get("pid")
    return pid is not None and meta.get("host") == socket.gethostname() and not pid_alive(pid)


def reports_incomplete(meta: dict) -> bool:
    """Whether the reports a finished run promises were abandoned (a signal) or cut short
    (the process died while writing them)."""
    rep = meta.get("reports")
    return rep == "incomplete" or (rep == "writing" and _process_gone(meta))


def effective_status(meta: dict, now: float | None = None) -> tuple[str, str]:
    """(status, why) -- ``running`` only while its process lives; ``done`` only once its
    reports are written (``reports incomplete`` otherwise)."""
    status = str(meta.get("status") or "unknown")
    if status == "done" and reports_incomplete(meta):
        return REPORTS_INCOMPLETE, ("its stages are complete but its report files were not all written; "
                                    "`ares resume` (or `ares report`) writes them")
    if status != "running":
        return status, ""
    now = time.time() if now is None else now
    pid, host, beat = meta.get("pid"), meta.get("host"), meta.get("heartbeat")
    if pid is not None and host == socket.gethostname() and not pid_alive(pid):
        return "interrupted", f"its process {pid} on {host} is gone (killed or crashed); `ares resume` continues it"
    if isinstance(beat, (int, float)) and now - beat > STALE_S:
        return "interrupted", (f"no heartbeat for {now - beat:.0f} s (process {pid} on {host}); "
                               "`ares resume` continues it")
    return "running", ""


def quiet_unraisable_storage_errors() -> None:
    """HDF5 reports a failed write again each time h5py frees one of the file's objects
    (a traceback through ``h5py/_objects.pyx`` printed by the excepthook, then "Exception
    ignored in: h5py._objects.ObjectID.__dealloc__"): the error itself is reported as one
    sentence, so those echoes of a storage error are dropped (nothing else is)."""
    import sys

    def echo(exc, tb) -> bool:
        while tb is not None:
            if "_objects.pyx" in tb.tb_frame.f_code.co_filename:
                return is_storage_error(exc)
            tb = tb.tb_next
        return False

    unraisable, excepthook = sys.unraisablehook, sys.excepthook
    if getattr(unraisable, "__name__", "") == "quiet_unraisable":
        return

    def quiet_unraisable(u):
        if not is_storage_error(u.exc_value):
            unraisable(u)

    def quiet_excepthook(typ, exc, tb):
        if not echo(exc, tb):
            excepthook(typ, exc, tb)

    sys.unraisablehook, sys.excepthook = quiet_unraisable, quiet_excepthook


class Heartbeat:
    """Calls ``beat()`` every ``interval`` seconds in a daemon thread until ``stop()``."""

    def __init__(self, beat, interval: float = HEARTBEAT_S):
        self._beat = beat
        self._interval = interval
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="ares-heartbeat", daemon=True)

    def start(self) -> "Heartbeat":
        self._thread.start()
        return self

    def _loop(self) -> None:
        while not self._stop.wait(self._interval):
            try:
                self._beat()
            except Exception:  # noqa: BLE001 -- the disk failed (OSError, or the writer's StorageError: the
                return  # run directory removed, full, read-only): the main thread reports it at its next write

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=10)
