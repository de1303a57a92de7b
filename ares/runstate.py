"""A run's state as its directory tells it, and the errors of the disk it is written to.

Imports nothing of the project, so that the writer (``ares.scan.rundir``), the report
(``ares.report.source``) and the GUI read a run's state the same way.

- ``run.json`` records who runs it: ``pid``, ``host``, ``heartbeat`` (seconds since the
  epoch, refreshed at least every ``HEARTBEAT_S`` while the process lives).
- ``effective_status(meta)``: a ``running`` run whose process is gone (same host, pid not
  alive) or whose heartbeat is older than ``STALE_S`` reads as ``interrupted`` -- a run
  killed by SIGKILL or a power cut never stays ``running`` forever.
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

STORAGE_ERRNOS = {
    errno.ENOSPC: "the disk is full",
    errno.EDQUOT: "the disk quota is exceeded",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EIO: "an input/output error",
    errno.ENOENT: "the directory does not exist (or disappeared)",
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


def effective_status(meta: dict, now: float | None = None) -> tuple[str, str]:
    """(status, why) -- ``running`` only while its process lives."""
    status = str(meta.get("status") or "unknown")
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


def storage_sentence(exc: OSError, path) -> str:
    why = STORAGE_ERRNOS.get(exc.errno, exc.strerror or type(exc).__name__)
    return f"cannot write {path}: {why}"


def is_storage_error(exc: BaseException) -> bool:
    return isinstance(exc, OSError) and exc.errno in STORAGE_ERRNOS


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
