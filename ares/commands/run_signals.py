"""Stop signals during ``ares run`` and ``ares resume``: SIGINT, SIGTERM and SIGHUP stop the scan after the stage in flight (a second one aborts), and a signal during the reports abandons them with the run's state on disk true.

From the first instruction to the last: ``install_early`` (called by ``ares.cli.main``
before it parses anything) records a signal that lands before the run's own handler
exists (loading the XML, the checks, the bench): the run then does not start (nothing
written, exit 130), or -- once the run directory is claimed -- stops before its first
stage. A signal after the last stage (the scan-level analyses, the reports, or after
everything) still ends the process with exit 130 and a sentence saying the run is complete.
"""

from __future__ import annotations

import signal
import sys
from pathlib import Path


class ReportsAbandoned(BaseException):
    """A signal while the reports were written (not an ``Exception``: nothing on the way
    treats it as a report error)."""


SIGNAL_NAMES = {signal.SIGINT: "Ctrl-C", signal.SIGTERM: "SIGTERM", signal.SIGHUP: "SIGHUP"}
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class _Early:
    """The process's stop signals before (and after) a run's own handler: their names in
    order (``received``), and whether a second one may end the process now (``raise_second``:
    not once a run directory is being claimed -- the run's handler takes them over)."""

    def __init__(self):
        self.received: list[str] = []
        self.raise_second = True
        self.old: dict = {}

    def __call__(self, signum, frame) -> None:
        name = SIGNAL_NAMES.get(signum, "signal")
        self.received.append(name)
        if len(self.received) == 1:
            sys.stderr.write(f"\n{name}: stopping before the run starts ({name} again to end now)\n")
        elif self.raise_second:
            raise KeyboardInterrupt


EARLY = _Early()


def install_early() -> None:
    """Record SIGINT/SIGTERM/SIGHUP from now on (the process's first instructions: a SIGHUP
    in a run's first second was lost -- its default, or an inherited ignore, before the
    run's handler existed); ``restore_early`` puts the previous handlers back."""
    EARLY.received.clear()
    EARLY.raise_second = True
    if _main_thread():
        EARLY.old = {s: signal.signal(s, EARLY) for s in STOP_SIGNALS}


def restore_early() -> None:
    for s, h in EARLY.old.items():
        signal.signal(s, h)
    EARLY.old = {}


def refuse_if_stopped(what: str) -> None:
    """Before a run claims anything: a stop signal that came already ends the command here
    (``Interrupted``, exit 130) with ``what`` -- the state of the disk -- said; later ones are
    the run's to handle (a second one no longer ends the process at once)."""
    from ares.errors import Interrupted

    EARLY.raise_second = False
    if EARLY.received:
        raise Interrupted(f"{EARLY.received[0]} before the run started: {what}")


def ended_anyway(command: str, rc: int) -> int:
    """The exit code of a command that returned ``rc`` although a stop signal came (after
    the run ended, or too late to change it): 130 and one sentence instead of 0."""
    if rc != 0 or not EARLY.received:
        return rc
    sys.stderr.write(f"ares {command}: {EARLY.received[0]} received after the run's work was done; "
                     "everything it did is complete\n")
    return 130


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

    SIGS = STOP_SIGNALS

    def __init__(self, runner=None):
        self.runner, self.hits, self.old = runner, 0, {}
        self.phase = "scan" if runner is not None else "reports"
        self.received = ""  # the signal that abandoned the reports (its name), once one did
        self._unraisable = None

    def install(self) -> "Signals":
        """Installed; the stop signals recorded before (``EARLY``) taken over: one stops the
        runner before its first stage, two abort it."""
        if _main_thread():
            self.old = {s: signal.signal(s, self) for s in self.SIGS}
            self._unraisable, sys.unraisablehook = sys.unraisablehook, self._lost
        self._seen = len(EARLY.received)
        self.hits = self._seen
        if self.runner is not None and self.hits:
            self.runner.stop()
            if self.hits > 1:
                self.runner.abort()
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

    @property
    def first(self) -> str:
        """The name of the first stop signal the run received ("" if none)."""
        return EARLY.received[0] if EARLY.received else ""

    def __call__(self, signum, frame) -> None:
        self.hits += 1
        name = SIGNAL_NAMES.get(signum, "signal")
        EARLY.received.append(name)
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


def complete_anyway(sigs: Signals, run_dir, command: str) -> int:
    """A stop signal came after the last stage was committed (during the scan-level
    analyses, or before the reports): the run is complete and run.json says ``done``; one
    line, exit 130."""
    sys.stderr.write(f"ares {command}: {sigs.first} after the last stage: nothing was left to stop, "
                     f"the run is complete in {run_dir}\n")
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
