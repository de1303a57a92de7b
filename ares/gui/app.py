"""Start the Qt application and show the main window.

Qt aborts the whole process (it does not raise) when it cannot reach a display or load
its platform plugin, so ``check_display()`` first probes Qt in a child process and turns
a failure into one ``AresError`` sentence.
"""

from __future__ import annotations

import os
import subprocess
import sys

from ares.errors import AresError

HEADLESS_PLATFORMS = ("offscreen", "minimal", "vnc", "eglfs", "linuxfb")
_PROBE = "from PySide6.QtWidgets import QApplication; QApplication(['ares-probe'])"


def check_display() -> None:
    """Raise ``AresError`` (one sentence) if a QApplication could not start here."""
    try:
        import pyqtgraph  # noqa: F401
        import PySide6  # noqa: F401
    except ImportError as exc:
        raise AresError(f"the GUI needs PySide6 and pyqtgraph (pip install 'ares[gui]'); {exc}.") from None
    platform = os.environ.get("QT_QPA_PLATFORM", "").split(":")[0]
    if (sys.platform.startswith("linux") and platform not in HEADLESS_PLATFORMS
            and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))):
        raise AresError("cannot open the GUI: no display (DISPLAY and WAYLAND_DISPLAY are unset); "
                        "run it in a desktop session or set QT_QPA_PLATFORM=offscreen.")
    try:
        probe = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise AresError(f"cannot open the GUI: Qt did not start ({exc}).") from None
    if probe.returncode != 0:
        lines = [ln.strip() for ln in probe.stderr.splitlines() if ln.strip()]
        reason = next((ln for ln in lines if "could not" in ln.lower() or "cannot" in ln.lower()),
                      lines[-1] if lines else f"exit status {probe.returncode}")
        raise AresError(f"cannot open the GUI: Qt could not start ({reason.rstrip('.')}).")


def make_app(argv: list[str] | None = None):
    """The QApplication (created once)."""
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance()
    if app is None:
        app = QApplication(list(argv) if argv is not None else sys.argv[:1])
        app.setApplicationName("ARES")
    return app


def open_main_window(scan: str | None = None):
    from ares.gui.main_window import MainWindow

    window = MainWindow()
    if scan:
        window.load_scan(scan)
    screen = window.screen().availableGeometry() if window.screen() is not None else None
    w, h = (1400, 900) if screen is None else (min(1400, screen.width()), min(900, screen.height()))
    window.resize(w, h)  # fits a 1280x800 screen (the window's minimum width is below 1100 px)
    window.show()
    return window
