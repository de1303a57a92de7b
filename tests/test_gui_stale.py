"""Nothing stale (issue 52): once Start is pressed, no tab shows anything of the previous
run -- the Signal Map kept the previous run's last image for ~6 s after Start -- and after
Stop every tab shows the stopped run's own data. The two runs have different sensor sizes,
so any image of the first one is recognised by its shape."""

from __future__ import annotations

import json
import os
import threading

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from PySide6.QtCore import Qt  # noqa: E402

from ares.gui.engine import DemoScan  # noqa: E402
from ares.gui.main_window import RESULT_TABS, MainWindow  # noqa: E402
from ares.gui.plots.lowlight_view import TAB, show_for_run  # noqa: E402
from test_gui import TIMEOUT_MS, idle, run_to_end, show_tab, tiny  # noqa: E402

# One window for the module (building one costs ~0.7 s): each test sets what it reads
# (a run, a Done summary, a loaded scan), so the order does not matter.


@pytest.fixture(scope="module")
def window(qapp):
    from PySide6.QtCore import QCoreApplication, QDeadlineTimer

    w = MainWindow()
    w.resize(1280, 800)
    w.show()
    w.confirm = lambda title, text: True  # never a modal question
    yield w
    if w.running:
        w.abort_scan()
    deadline = QDeadlineTimer(TIMEOUT_MS)
    while not idle(w) and not deadline.hasExpired():
        QCoreApplication.processEvents()
    w.close()
    w.deleteLater()

pytestmark = pytest.mark.gui
FIRST, SECOND = (12, 16), (10, 14)


class HeldAtStart(DemoScan):
    """Holds before its first frame until the test opens the gate."""

    def __init__(self):
        super().__init__(shape=SECOND, frames=3, levels_e=(0, 100, 400))
        self.gate = threading.Event()
        self.calls = 0

    def checkpoint(self):
        self.calls += 1
        if self.calls == 1:
            self.gate.wait(TIMEOUT_MS / 1000)
        super().checkpoint()


def _images(w) -> dict:
    """Every image a tab shows, model and widget: name -> array or None."""
    s = w.session
    return {"live model": s.preview.image, "signal map model": s.signal_map.image,
            "noise map model": s.noise_map.image, "live widget": w.preview.image_item.image,
            "signal map widget": w.signal_map.image_item.image, "noise map widget": w.noise_map.image_item.image}


def _shown_everywhere(w) -> None:
    for name in RESULT_TABS:
        show_tab(w, name)


def test_start_and_stop_show_nothing_of_the_previous_run(window, qtbot, tmp_path):
    window.set_job_factory(tiny(shape=FIRST))
    run_to_end(qtbot, window)
    _shown_everywhere(window)
    assert window.session.signal_map.image.shape == FIRST  # the first run is on screen
    # stage numbers are the index from 0 (docs/quantities.md) in the browser and captions;
    # the Current Stage is a count
    bar = window.view_bar.stage
    assert [bar.itemText(i) for i in range(1, bar.count())] == ["0: dark", "1: 100 e-", "2: 400 e-"]
    assert window.session.signal_map.caption.startswith("stage 2: 400 e-")
    assert window.session.progress.stage_text == "3 of 3 (400 e-)"
    first_info = dict(window.session.info.items)
    # a run with an RTN map leaves a Low Light tab (ares.gui.plots.lowlight_view); Start takes it away
    rtn_dir = tmp_path
    (rtn_dir / "scan_results.json").write_text(json.dumps({"analyses": {"rtn": {
        "rtn_pixels": 1, "pixels": 4, "frames": 1000, "stage": "dark",
        "map": {"shape": [2, 2], "rows": [1], "cols": [0], "amplitude": [3.0]}}}}))
    assert show_for_run(window.result_tabs, rtn_dir) is not None

    job = HeldAtStart()
    window.set_job_factory(lambda: job)
    try:
        _second_run(window, qtbot, job, first_info)
    finally:
        job.gate.set()  # (a failed check must not leave the demo held)


def _second_run(window, qtbot, job, first_info) -> None:
    qtbot.mouseClick(window.buttons.start, Qt.MouseButton.LeftButton)
    _shown_everywhere(window)
    s = window.session
    for name, img in _images(window).items():  # straight after Start: empty
        assert img is None, f"after Start, {name} still shows the previous run's image {img.shape}"
    assert all(m.values.size == 0 for m in s.panels.values()), "Results panels of the previous run"
    assert all(m.values.size == 0 for m in s.distributions.values()), "Pixel Distributions of the previous run"
    assert not s.profiles.columns and not s.profiles.rows, "Profiles of the previous run"
    assert not s.ptc.points and not s.components.views and not s.stages.results
    assert not s.sweep.points
    tabs = window.result_tabs
    assert TAB not in [tabs.tabText(i) for i in range(tabs.count())], "the previous run's Low Light tab"
    for k, v in first_info.items():  # the previous run's figures are gone from the Information tab
        if k.startswith("PTC") or k in ("gain",):
            assert s.info.items.get(k) != v, k

    qtbot.mouseClick(window.buttons.stop, Qt.MouseButton.LeftButton)
    job.gate.set()
    qtbot.waitUntil(lambda: idle(window), timeout=TIMEOUT_MS)
    _shown_everywhere(window)
    for name, img in _images(window).items():  # after Stop: the stopped run's, or nothing
        assert img is None or img.shape == SECOND, f"after Stop, {name} shows an image of shape {img.shape}"


def test_thresholds_table_shows_the_run_s_values(window):
    """The Defect Counts tab's thresholds are the ones the run used (its scan's <defects>),
    not the defaults it did not use; an edit is what differs from the run's."""
    from ares.gui.events import Done
    from ares.gui.runner_adapter import summarize

    window.session.handle(Done(summary=summarize({}, (("hot_e_per_s", 1000.0),))))
    show_tab(window, "Defect Counts")
    view = window.defects
    row = list(view.defaults).index("hot_e_per_s")
    assert view.thresholds.item(row, 1).text() == "1000"
    assert view.overrides() == {}
    view.set_threshold("hot_e_per_s", "5")
    assert view.overrides() == {"hot_e_per_s": "5"}


def test_stage_list_follows_frames_per_stage(window, monkeypatch):
    """The Scan tab's stage list shows the frames each stage will take: Frames per stage
    replaces the scan's counts (issue 52), and the stages are numbered from 0 as in the files.
    (Loading warms the run's imports and numba kernels for a smooth Start: ~1.5 s of CPU this
    test does not need, so it is skipped here.)"""
    from pathlib import Path

    from ares.gui import runner_adapter
    from ares.sim import fused

    monkeypatch.setattr(runner_adapter, "warm_imports", lambda: None)
    monkeypatch.setattr(fused, "warm", lambda: None)

    scan = Path(__file__).resolve().parents[1] / "scans" / "lag.xml"
    assert window.load_scan(str(scan))
    panel = window.controls.scan
    before = panel.details.toPlainText()
    assert "\n  0  " in before
    panel.frames.setValue(5)
    after = panel.details.toPlainText()
    stages = after.split("Stages (Frames per stage: 5):\n", 1)[1].splitlines()
    assert stages and all(" 5 frames" in ln for ln in stages), stages
    assert all("+ 5 dark" in ln for ln in stages if " + " in ln and "reused" not in ln), stages
