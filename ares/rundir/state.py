"""A run's state as its directory tells it, and the errors of the disk it is written to.

Imports nothing of the project, so that the writer (``ares.rundir.writer``), the report
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

import errno
import os
import socket
import threading
import time

HEARTBEAT_S = 5.0
STALE_S = 120.0

REPORTS_INCOMPLETE = "reports incomplete"

STORAGE_ERRNOS = {
    errno.ENOSPC: "the disk is full",
    errno.EFBIG: "the file is larger than the file-size limit (ulimit -f) or the file system allows",
    errno.EDQUOT: "the disk quota is exceeded",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EIO: "an input/output error",
    errno.ENOENT: "the directory does not exist (or disappeared)",
    errno.ENOTDIR: "a folder of the path is a file",
    errno.EISDIR: "the path is a directory",
    errno.EMFILE: "too many files are open",
    errno.ENFILE: "too many files are open on the system",
    errno.ENAMETOOLONG: "the file name is too long",
    errno.ESTALE: "the network file system lost the file (stale handle)",
    errno.ENXIO: "the device is gone",
    errno.ENODEV: "the device is gone",
}


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


def os_errno(exc: BaseException) -> int | None:
    """The errno of an OS error, also when a library wraps it in its message only
    (h5py/HDF5 raise OSError or RuntimeError "... file write failed: ... filename = 'x',
    ... errno = 27, error message = 'File too large' ...")."""
    if isinstance(exc, OSError) and exc.errno is not None:
        return exc.errno
    if not isinstance(exc, (OSError, RuntimeError)):
        return None
    import re

    m = re.search(r"errno = (\d+)", str(exc))
    return int(m.group(1)) if m else None


def storage_sentence(exc: BaseException, path) -> str:
    """One sentence: the file (the error's own when it names one) and what the disk said."""
    import re

    code = os_errno(exc)
    why = STORAGE_ERRNOS.get(code, getattr(exc, "strerror", None) or type(exc).__name__)
    named = getattr(exc, "filename", None)
    if named is None:
        m = re.search(r"filename = '([^']*)'", str(exc))
        named = m.group(1) if m else None
    return f"cannot write {named or path}: {why}"


def is_storage_error(exc: BaseException) -> bool:
    return os_errno(exc) in STORAGE_ERRNOS


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
            except OSError:  # the disk failed: the main thread reports it at its next write
                return

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=10)
