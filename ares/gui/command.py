"""``ares gui [SCAN]``: open the ARES window, optionally with a scan XML loaded."""

from __future__ import annotations

from pathlib import Path

from ares.errors import InputError

NAME = "gui"
HELP = "open the ARES window (live plots, regions of analysis, scan control)"


def add_arguments(parser) -> None:
    parser.add_argument("scan", nargs="?", help="scan XML to load (Start Scan runs it); "
                        "without it Start Scan runs a built-in demo on a simulated sensor")


def run(args) -> int:
    if args.scan:
        if not Path(args.scan).is_file():
            raise InputError(f"{args.scan}: no such scan file.")
        from ares.gui.engine import open_scan

        open_scan(args.scan)  # a broken scan ends here in one sentence, before any window
    from ares.gui.app import check_display

    check_display()
    from ares.gui.app import make_app, open_main_window  # Qt is imported here, not at module load

    app = make_app()
    window = open_main_window(args.scan)
    stops = quit_on_signals(app, window)
    try:
        rc = int(app.exec())
    finally:
        stops.restore()
    return 130 if stops.received else rc


class _Stops:
    """The window's SIGINT/SIGTERM/SIGHUP handling (``quit_on_signals``)."""

    SIGS = ("SIGINT", "SIGTERM", "SIGHUP")

    def __init__(self, app, window):
        import signal

        from PySide6.QtCore import QTimer

        self.app, self.window, self.received = app, window, []
        self.old = {getattr(signal, s): signal.signal(getattr(signal, s), self) for s in self.SIGS}
        # Python runs a signal's handler only between its own instructions; while Qt waits in
        # its event loop none run, so Ctrl-C was ignored once the window was up: a timer gives
        # the interpreter a turn five times a second
        self.tick = QTimer(app)
        self.tick.timeout.connect(lambda: None)
        self.tick.start(200)

    def __call__(self, signum, frame) -> None:
        from PySide6.QtCore import QTimer

        self.received.append(signum)
        if len(self.received) == 1:  # (in Qt's turn, not inside the handler)
            QTimer.singleShot(0, self._quit)
        else:  # a second one: now, whatever is still being finished
            QTimer.singleShot(0, lambda: self.app.exit(130))

    def _quit(self) -> None:
        """Close the window as its close button does, without the question: a running scan is
        aborted (the stage in flight dropped, the completed ones kept) and the window closes
        once the run directory is complete."""
        w = self.window
        if getattr(w, "running", False):
            w.abort_scan()
        w._closing = True
        w.close()

    def restore(self) -> None:
        import signal

        self.tick.stop()
        for s, h in self.old.items():
            signal.signal(s, h)


def quit_on_signals(app, window) -> _Stops:
    """Ctrl-C, SIGTERM and SIGHUP close the window (a scan is aborted, its run directory
    finished first); a second one ends the event loop at once. ``restore()`` undoes it."""
    return _Stops(app, window)
