"""Stop signals during ``ares run`` and ``ares resume``: SIGINT, SIGTERM and SIGHUP stop the scan after the stage in flight (a second one aborts), and a signal during the reports abandons them with the run's state on disk true."""

from __future__ import annotations

import signal
import sys
from pathlib import Path


class ReportsAbandoned(BaseException):
    """A signal while the reports were written (not an ``Exception``: nothing on the way
    treats it as a report error)."""


SIGNAL_NAMES = {signal.SIGINT: "Ctrl-C", signal.SIGTERM: "SIGTERM", signal.SIGHUP: "SIGHUP"}


class Signals:
    """The run's SIGINT/SIGTERM/SIGHUP handler. During the scan (``phase`` "scan") the first
    signal stops after the current stage and a second aborts; during the reports (``phase``
    "reports") the first abandons them (``ReportsAbandoned`` is raised where the main thread
    is) and any later one is ignored while that is recorded.

    Python runs a handler wherever the main thread is, also inside a weakref callback or a
    ``__del__`` that the garbage collector started: an exception raised there is printed
    ("Exception ignored in ...", a traceback) and dropped. Such a lost ``ReportsAbandoned``
    is not printed; the handler is armed again (a second signal abandons the reports), and
    ``received`` tells the caller that a signal came though the reports were finished."""

    SIGS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

    def __init__(self, runner=None):
        self.runner, self.hits, self.old = runner, 0, {}
        self.phase = "scan" if runner is not None else "reports"
        self.received = ""  # the signal that abandoned the reports (its name), once one did
        self._unraisable = None

    def install(self) -> "Signals":
        if _main_thread():
            self.old = {s: signal.signal(s, self) for s in self.SIGS}
            self._unraisable, sys.unraisablehook = sys.unraisablehook, self._lost
        return self

    def restore(self) -> None:
        for s, h in self.old.items():
            signal.signal(s, h)
        self.old = {}
        if self._unraisable is not None:
            sys.unraisablehook, self._unraisable = self._unraisable, None

    def _lost(self, u) -> None:
        """``sys.unraisablehook`` while installed: a ``ReportsAbandoned`` raised inside a
        weakref callback or ``__del__`` was dropped there -- armed again, not printed."""
        if isinstance(u.exc_value, ReportsAbandoned) and self.phase == "abandoning":
            self.phase = "reports"
            return
        self._unraisable(u)

    def __call__(self, signum, frame) -> None:
        self.hits += 1
        name = SIGNAL_NAMES.get(signum, "signal")
        if self.phase == "reports":
            self.phase, self.received = "abandoning", name
            raise ReportsAbandoned(name)
        if self.phase == "abandoning":
            return
        if self.hits == 1:
            sys.stderr.write(f"\n{name}: stopping after the current stage ({name} again to abort)\n")
            self.runner.stop()
        else:
            self.runner.abort()


def abandon_reports(exc: ReportsAbandoned, run_dir, helper, command: str, stages: int) -> int:
    """After a signal during the reports: the helper ended, the temporary files removed,
    run.json saying ``reports incomplete``; one line, exit 130."""
    from ares.rundir.record import clean_report_leftovers, set_reports_state

    if helper is not None:
        helper.kill()
    if run_dir is not None:
        clean_report_leftovers(Path(run_dir))
        set_reports_state(run_dir, "incomplete", report_note=f"{exc} while the reports were written")
    sys.stderr.write(f"ares {command}: {exc} while writing the reports: the {stages} completed stage(s) are kept in "
                     f"{run_dir}, the reports are incomplete; `ares resume {run_dir}` writes them\n")
    return 130


def finished_anyway(sigs: Signals, run_dir, command: str) -> int:
    """A signal came while the reports were written but its ``ReportsAbandoned`` was lost
    (``Signals``): the reports were finished, run.json says so; one line, exit 130."""
    sys.stderr.write(f"ares {command}: {sigs.received} while writing the reports, which were finished first: "
                     f"the run is complete in {run_dir}\n")
    return 130


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
