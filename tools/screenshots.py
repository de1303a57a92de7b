"""The README's screenshots: the window at 1280x800 during and after real scans on the
simulated bench. Run under Xvfb (``make screenshots`` does) or with
QT_QPA_PLATFORM=offscreen; writes PNGs to docs/screenshots/ (or the folder given).

    xvfb-run -a -s "-screen 0 1280x800x24" .venv/bin/python tools/screenshots.py [OUT_DIR]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def wait(app, cond, timeout_s: float = 900) -> None:
    """Run the event loop until ``cond()`` holds (a bound, not a speed requirement)."""
    t0 = time.monotonic()
    while not cond():
        app.processEvents()
        time.sleep(0.01)
        if time.monotonic() - t0 > timeout_s:
            raise SystemExit("screenshots: the scan did not get there in time")


def settle(app, seconds: float = 0.4) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        app.processEvents()
        time.sleep(0.01)


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "screenshots"
    out.mkdir(parents=True, exist_ok=True)
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication([])
    from ares.gui.main_window import RESULT_TABS, MainWindow

    w = MainWindow()
    w.resize(1280, 800)
    w.show()
    runs = tempfile.mkdtemp(prefix="ares-shots-")
    w.controls.output.directory.setText(runs)
    s = w.session

    def show(tab: str) -> None:
        w.result_tabs.setCurrentIndex(RESULT_TABS.index(tab))

    def shot(name: str, tab: str | None = None, control: int | None = None) -> None:
        if tab is not None:
            show(tab)
        if control is not None:
            w.controls.setCurrentIndex(control)
        settle(app)
        path = out / f"{name}.png"
        w.grab().save(str(path))
        try:  # a 256-colour palette: a third of the bytes in the repository, the same picture to the eye
            from PIL import Image

            Image.open(path).convert("RGB").quantize(256).save(path, optimize=True)
        except ImportError:
            pass
        print(path)

    assert w.load_scan(ROOT / "scans" / "photon_transfer.xml")
    w.session.regions.update(1, on=True, draw=True, x=400, y=260, width=160, height=120)
    w.start_scan()
    wait(app, lambda: s.progress.stage >= 12)
    shot("1_scan_results", "Results", control=1)
    wait(app, lambda: s.progress.stage >= 18)
    w.view_bar.choose_view("full")  # the view the engine's gain fit is of: its verdict per level drawn
    shot("2_scan_ptc", "PTC", control=0)
    shot("3_scan_components", "Components")
    wait(app, lambda: not w.running and not w.finishing)
    show("Defect Counts")  # a tab is drawn when shown: then its controls, as a user would
    w.defects.overlay.setChecked(True)
    shot("4_defects_overlay")
    w.view_bar.choose_stage(None)
    assert w.load_scan(ROOT / "scans" / "bias_sweep_2d.xml")
    w.start_scan()
    wait(app, lambda: not w.running and not w.finishing)
    show("Sweep Map")
    assert "image lag (%)" in s.sweep.quantities, s.sweep.quantities
    w.sweep.quantity.setCurrentText("image lag (%)")
    shot("5_bias_sweep_lag_map")
    tab = w.controls.instruments
    tab.path.setText(str(ROOT / "protocols" / "sim_sensor.xml"))
    tab.choose(str(ROOT / "protocols" / "sim_sensor.xml"))
    tab.connect_button.setChecked(True)
    tab._grab()
    w.left_split.setSizes([560, 200])  # room for the register table
    shot("6_instrumentation", "Signal Map", control=4)
    w.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
