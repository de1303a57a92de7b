"""Issue 54: ``ares gui`` ignored Ctrl-C once its window was up (Qt's event loop gave the
interpreter no turn to run the handler). Now Ctrl-C, SIGTERM and SIGHUP close the window
as its close button does -- a scan running is aborted first, its run directory finished --
and ``ares gui`` exits 130."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

pytestmark = pytest.mark.gui
ROOT = Path(__file__).resolve().parents[1]

# ``ares gui`` as the script runs it, saying "up" from the event loop once (a Python slot
# that runs once: afterwards the loop waits in Qt, where Ctrl-C used to be lost)
_CHILD = r"""
import sys
from PySide6.QtCore import QTimer
from ares.gui.app import make_app
app = make_app()
QTimer.singleShot(0, lambda: print("up", flush=True))
from ares.cli import main
sys.exit(main(["gui"]))
"""


@pytest.mark.parametrize("sig", [signal.SIGINT])
def test_ctrl_c_closes_the_window_waiting_in_the_event_loop(sig):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "QT_QPA_PLATFORM": "offscreen"}
    p = subprocess.Popen([sys.executable, "-c", _CHILD], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    try:
        assert p.stdout.readline().strip() == "up", p.stderr.read()
        p.send_signal(sig)
        out, err = p.communicate(timeout=600)  # (a bound on a hang, not a speed requirement)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 130 and "Traceback" not in err, err
