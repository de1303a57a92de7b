"""The ARES window under pytest-qt (QT_QPA_PLATFORM=offscreen): build, RoA table, a
scan from the Start button to done, stop/pause/abort, auto repeat, errors."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from PySide6.QtCore import Qt  # noqa: E402

from ares.errors import AresError, HardwareError, InputError  # noqa: E402
from ares.gui import events as E  # noqa: E402
from ares.gui.engine import DemoScan  # noqa: E402
from ares.gui.main_window import RESULT_TABS, MainWindow  # noqa: E402
from ares.gui.models import progress as P  # noqa: E402
from ares.gui.models.regions import Region  # noqa: E402
from ares.gui.scan_panel import CONTROL_TABS  # noqa: E402

pytestmark = pytest.mark.gui
TIMEOUT_MS = 600_000  # a bound on waiting for an event, not a speed requirement (a busy CI machine is slow)


@pytest.fixture
def window(qtbot):
    w = MainWindow()
    qtbot.addWidget(w)
    w.resize(1400, 900)
    w.show()
    w.confirm = lambda title, text: True  # never a modal question (pytest-qt closes the window first)
    yield w
    if w.running:
        w.abort_scan()
    qtbot.waitUntil(lambda: idle(w), timeout=TIMEOUT_MS)


def tiny(**kw):
    args = dict(shape=(12, 16), frames=3, levels_e=(0, 100, 400))
    args.update(kw)
    return lambda: DemoScan(**args)


def show_tab(w, name: str) -> None:
    """Bring a result tab on screen (hidden tabs are computed when shown)."""
    w.result_tabs.setCurrentIndex(RESULT_TABS.index(name))


def idle(w) -> bool:
    """No scan taking frames and no ended run still writing its directory."""
    return not w.running and not w.finishing


def run_to_end(qtbot, w):
    qtbot.mouseClick(w.buttons.start, Qt.MouseButton.LeftButton)
    assert w.running
    qtbot.waitUntil(lambda: idle(w), timeout=TIMEOUT_MS)


def test_window_builds_with_ares_tabs_and_controls(window):
    c = window.controls
    assert [c.tabText(i) for i in range(c.count())] == list(CONTROL_TABS)
    r = window.result_tabs
    assert [r.tabText(i) for i in range(r.count())] == list(RESULT_TABS)
    b = window.buttons
    assert (b.start.text(), b.stop.text(), b.auto_repeat.text()) == ("Start Scan", "Stop Scan", "Auto Repeat")
    assert b.start.isEnabled() and not b.stop.isEnabled()
    assert window.progress_line.stage.text() == P.IDLE_TEXT
    assert set(window.results.panels) == {"MEAN SIGNAL", "NOISE", "COLUMNS", "ROWS"}
    assert window.session.info.items["ARES version"]


def test_roa_table_add_edit_toggle_and_file_round_trip(window, qtbot, tmp_path):
    table = window.controls.regions
    regions = window.session.regions
    table.add_region(Region(True, False, 4, 6, 128, 108))
    assert table.table.item(0, 2).text() == "4"
    table.set_cell(0, 4, 64)  # edit Width in the table
    assert regions[0].width == 64
    table.set_cell(0, 0, False)  # On/Off
    table.set_cell(0, 1, True)  # Draw
    assert (regions[0].on, regions[0].draw) == (False, True)
    with qtbot.waitSignal(table.error) as blocker:
        table.set_cell(0, 3, "six")
    assert blocker.args == ["Region 1: Y must be a whole number."]
    assert table.table.item(0, 3).text() == "6" and regions[0].y == 6
    table.set_cell(1, 0, True)
    table.set_cell(1, 4, 10)
    table.set_cell(1, 5, 5)
    path = tmp_path / "regions.xml"
    assert table.save(str(path))
    saved = list(regions.regions)
    regions.replace_all([])
    assert table.table.item(0, 4).text() == "0"
    assert table.load(str(path))
    assert regions.regions == saved and table.table.item(0, 4).text() == "64"
    bad = tmp_path / "bad.csv"
    bad.write_text("on,draw,x,y,width,height\n2,0,0,0,1,1\n")
    assert not table.load(str(bad))
    assert window.last_error == f"{bad}, line 2: on must be 0 or 1, not 2."


def test_scan_runs_from_start_button_to_done(window, qtbot):
    window.set_job_factory(tiny())
    window.session.regions.add(Region(True, True, 2, 3, 10, 6))
    window.session.regions.add(Region(True, False, 0, 0, 16, 12))
    stages = []
    window.session.progress.subscribe(lambda m: stages.append(window.progress_line.stage.text()))
    run_to_end(qtbot, window)
    s = window.session
    assert s.progress.state == P.DONE
    assert window.progress_line.stage.text() == "3 of 3 (400 e-)"
    assert window.progress_line.remaining.text() == "0 : 00 : 00"
    assert any(t.startswith("1 of 3") for t in stages) and any(t.startswith("2 of 3") for t in stages)
    # plots received data: pixel distributions hold every ROI pixel of the last frame
    assert s.distributions == {}  # hidden while the scan ran: not computed ...
    show_tab(window, "Pixel Distributions")  # ... until shown
    assert {i: int(m.counts.sum()) for i, m in s.distributions.items()} == {0: 60, 1: 192}
    for name in ("Signal Map", "Profiles"):
        show_tab(window, name)
    assert set(window.distributions.plots) == {0, 1}
    assert s.panels["MEAN SIGNAL"].counts.sum() == 60
    assert window.results.panels["MEAN SIGNAL"].labels["mean"].text() != "n/a"
    show_tab(window, "PTC")
    assert len(s.ptc.points) == 2 and len(window.ptc.sets["pending"].xData) == 2  # no engine fit in the demo
    assert window.preview.image_item.image is not None and window.preview.rectangle_count == 2
    assert set(window.preview.rois) == {0}  # Draw ticked: editable with the mouse
    assert window.signal_map.image_item.image.shape == (12, 16)
    assert sorted(s.profiles.columns) == [0, 1]
    assert window.buttons.start.isEnabled() and not window.buttons.abort.isEnabled()
    assert window.last_error is None


def test_results_panel_range_controls(window, qtbot):
    window.set_job_factory(tiny())
    run_to_end(qtbot, window)
    panel = window.results.panels["NOISE"]
    model = panel.model
    n = model.stats.n
    panel.to.setValue(model.stats.lowest + 0.5 * (model.stats.highest - model.stats.lowest))
    panel.to.editingFinished.emit()
    assert model.range_mode == "Manual" and model.stats.n < n
    assert panel.mode.currentText() == "Manual"
    qtbot.mouseClick(panel.restore_button, Qt.MouseButton.LeftButton)
    assert model.range_mode == "Peak to Peak" and model.stats.n == n
    panel.mode.setCurrentText("Mean ± 3 Sigma")
    assert model.range_mode == "Mean ± 3 Sigma"


class Gated(DemoScan):
    """A demo scan that holds before its second frame until the test opens the gate,
    so stop/pause/abort land mid-stage however fast or slow the machine is."""

    def __init__(self):
        super().__init__(shape=(12, 16), frames=4, levels_e=(0, 10, 20, 30, 40))
        self.gate = threading.Event()
        self.calls = 0

    def checkpoint(self):
        self.calls += 1
        if self.calls == 2:
            self.gate.wait(TIMEOUT_MS / 1000)
        super().checkpoint()


def start_gated(qtbot, w):
    job = Gated()
    w.set_job_factory(lambda: job)
    qtbot.mouseClick(w.buttons.start, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: w.session.progress.frame >= 1, timeout=TIMEOUT_MS)
    return job


def test_stop_finishes_stage_in_flight_then_stops(window, qtbot):
    job = start_gated(qtbot, window)
    qtbot.mouseClick(window.buttons.stop, Qt.MouseButton.LeftButton)
    assert window.progress_line.state.text() == P.STOPPING
    job.gate.set()
    qtbot.waitUntil(lambda: idle(window), timeout=TIMEOUT_MS)
    s = window.session
    assert s.progress.state == P.STOPPED
    assert s.last_result is not None and s.last_result.stage == 0  # the stage in flight was finished
    assert "completed stages are kept" in window.statusBar().currentMessage()


def test_pause_resume_and_abort(window, qtbot):
    job = start_gated(qtbot, window)
    qtbot.mouseClick(window.buttons.pause, Qt.MouseButton.LeftButton)
    assert job.paused and window.buttons.pause.text() == "Resume"
    assert window.progress_line.state.text() == P.PAUSED
    qtbot.mouseClick(window.buttons.pause, Qt.MouseButton.LeftButton)
    assert not job.paused and window.progress_line.state.text() == P.RUNNING
    qtbot.mouseClick(window.buttons.pause, Qt.MouseButton.LeftButton)  # pause again, then abort
    qtbot.mouseClick(window.buttons.abort, Qt.MouseButton.LeftButton)
    job.gate.set()
    qtbot.waitUntil(lambda: idle(window), timeout=TIMEOUT_MS)
    assert window.session.progress.state == P.STOPPED
    assert "aborted" in window.session.progress.message
    assert window.session.last_result is None  # the stage in flight was dropped
    assert window.last_error is None


def test_auto_repeat_starts_the_scan_again(window, qtbot):
    window.set_job_factory(tiny(shape=(6, 6), frames=2, levels_e=(0, 10)))
    window.buttons.auto_repeat.setChecked(True)
    qtbot.mouseClick(window.buttons.start, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: window.runs_started >= 3, timeout=TIMEOUT_MS)
    window.buttons.auto_repeat.setChecked(False)
    qtbot.waitUntil(lambda: idle(window), timeout=TIMEOUT_MS)
    assert window.session.progress.state == P.DONE
    started = window.runs_started
    qtbot.wait(50)  # a next run queued as the last one ended is not started once unticked
    assert window.runs_started == started and idle(window)


def test_unticking_auto_repeat_as_a_run_ends_starts_no_other(window, qtbot):
    """The next run is queued when a run ends; unticked before it starts, it does not."""
    window.set_job_factory(tiny(shape=(6, 6), frames=2, levels_e=(0, 10)))
    window.buttons.auto_repeat.setChecked(True)
    run_to_end(qtbot, window)  # ends with the next run queued
    window.buttons.auto_repeat.setChecked(False)
    qtbot.wait(50)
    assert window.runs_started == 1 and idle(window)


class Broken(DemoScan):
    def __init__(self, exc):
        super().__init__(shape=(4, 4), frames=2, levels_e=(0, 10))
        self.exc = exc

    def run(self, emit):
        emit(E.StageStarted(1, 2, "dark", 2))
        raise self.exc


@pytest.mark.parametrize("exc, message", [
    (HardwareError("Camera 'sim0' stopped answering during stage 1."), "Camera 'sim0' stopped answering during stage 1."),
    (ZeroDivisionError("division by zero"), "Unexpected error in the scan engine: ZeroDivisionError (division by zero)."),
])
def test_engine_error_shows_one_sentence(window, qtbot, exc, message):
    window.set_job_factory(lambda: Broken(exc))
    run_to_end(qtbot, window)
    assert window.last_error == message
    assert window.error_box is not None and window.error_box.text() == message
    assert "Traceback" not in window.error_box.text() and "\n" not in message
    assert window.statusBar().currentMessage() == message
    assert window.session.progress.state == P.FAILED
    assert window.buttons.start.isEnabled()


def test_load_missing_scan_is_one_sentence(window, tmp_path):
    assert not window.load_scan(tmp_path / "nope.xml")
    assert window.last_error == f"{tmp_path / 'nope.xml'}: no such scan file."


def test_display_image_file_fills_preview_and_distributions(window, tmp_path):
    from PIL import Image

    img = (np.arange(48, dtype=np.uint16).reshape(6, 8) * 100)
    path = tmp_path / "frame.png"
    Image.fromarray(img).save(path)
    window.show_image_file(str(path))
    assert window.session.preview.caption == "frame.png"
    show_tab(window, "Pixel Distributions")
    assert window.session.distributions[-1].counts.sum() == 48


def test_gui_command_without_display_is_one_sentence(monkeypatch):
    from ares.gui import command as cmd
    from ares.gui.app import check_display

    monkeypatch.setenv("QT_QPA_PLATFORM", "xcb")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(AresError, match=r"^cannot open the GUI: no display .*\.$"):
        check_display()
    import argparse

    with pytest.raises(InputError, match="no such scan file"):
        cmd.run(argparse.Namespace(scan="does-not-exist.xml"))


# ---- the real runner (ares.scan) on the small simulated fixture scan ------------------------------
FIXTURES = os.path.join(os.path.dirname(__file__), os.pardir, "fixtures", "xml")
PTC_SMALL = os.path.join(FIXTURES, "small", "ptc_small.xml")


def ptc_small_with(tmp_path, output: str) -> str:
    """A copy of ptc_small (4 frames a stage) whose <output> is ``output`` (e.g. only the reports a test needs)."""
    text = open(PTC_SMALL).read().replace('href="sim_small.xml"', f'href="{os.path.dirname(PTC_SMALL)}/sim_small.xml"')
    (tmp_path / "ptc_small_copy.xml").write_text(text.replace('<output raw_frames="true"/>', output))
    return str(tmp_path / "ptc_small_copy.xml")


def test_the_results_caption_says_when_the_newest_stage_is_drawn_at_intervals(window):
    """While a scan runs the Results tab shows the newest stage at most every RESULTS_S:
    its caption says so (a stage shown from a while ago is not mistaken for a stuck scan),
    and no longer once the scan is over."""
    from ares.gui.events import Done, StageResult

    s, tab = window.session, window.results
    s.begin_run("t")
    s.handle(StageResult(0, "dark", np.ones((4, 5)), np.ones((4, 5)), 3))
    assert tab.caption.text() == ("Stage 0 (dark), 3 frames, full frame (while the scan runs, its newest stage "
                                  "is drawn at most every 3 s)")
    s.handle(StageResult(1, "flat", np.full((4, 5), 9.0), np.ones((4, 5)), 3))
    s.handle(Done(None, {}))
    assert tab.caption.text() == "Stage 1 (flat), 3 frames, full frame"


def test_results_panels_are_computed_off_the_window_s_thread_during_a_scan(window, qtbot, tmp_path, monkeypatch):
    """While a scan runs the Results panels' statistics (1-2 s a panel on a 12 Mpx sensor)
    are computed in the window's stats thread; after the scan, in the window's."""
    import threading

    pytest.importorskip("ares.scan")
    from ares.gui.models import stats
    from ares.gui.models.stats import MEAN_3_SIGMA

    where = []
    compute = stats.panel_state

    def traced(*a, **k):
        where.append(threading.current_thread().name)
        return compute(*a, **k)

    monkeypatch.setattr(stats, "panel_state", traced)
    assert window.load_scan(PTC_SMALL)
    window.controls.output.directory.setText(str(tmp_path))
    run_to_end(qtbot, window)
    assert window.session.progress.state == P.DONE, window.session.progress.message
    during = set(where)
    assert any(n.startswith("ares-gui-stats") for n in during), during
    assert window.session.panels["MEAN SIGNAL"].stats.n == 16 * 12  # the region, shown
    where.clear()
    window.session.panels["MEAN SIGNAL"].set_range_mode(MEAN_3_SIGMA)  # a user's choice after it
    assert where == [threading.main_thread().name]


def test_runner_scan_from_file_to_done(window, qtbot, tmp_path):
    pytest.importorskip("ares.scan")
    assert window.load_scan(PTC_SMALL)
    # the scan's region fills the RoA table, on and drawn
    assert window.session.regions[0] == Region(True, True, 8, 6, 16, 12)
    assert window.controls.regions.table.item(0, 4).text() == "16"
    assert "ptc_small" in window.controls.scan.file.text()
    window.controls.output.directory.setText(str(tmp_path))
    run_to_end(qtbot, window)
    s = window.session
    assert s.progress.state == P.DONE, s.progress.message
    assert window.progress_line.stage.text() == "9 of 9 (ptc[7])"
    show_tab(window, "Pixel Distributions")
    assert s.distributions[0].counts.sum() == 16 * 12
    assert s.panels["MEAN SIGNAL"].stats.n == 16 * 12
    assert len(s.ptc.points) == 8 and s.ptc.gain_e_per_dn > 0  # the engine's fit, drawn as a line
    assert window.ptc.line.xData is None  # a tab not in front is not drawn ...
    show_tab(window, "PTC")
    assert window.ptc.line.xData is not None  # ... until it is shown
    run_dir = s.info.items["run directory"]
    assert os.path.isdir(run_dir) and run_dir.startswith(str(tmp_path))
    from ares.labels import PTC_LABELS

    assert f"PTC: {PTC_LABELS['read_noise_e']}" in s.info.items
    assert window.preview.rectangle_count == 1
    # the engine's noise decomposition of the last stage, per view
    assert {"full", "centre"} <= set(s.components.views)
    symbols = [r.symbol for which in ("components", "dark_components") for r in s.components.rows(which)]
    assert {"Pt", "Ps", "Cs", "Rt"} <= set(symbols)
    show_tab(window, "Components")
    shown = sum(t.rowCount() for t in window.components.tables.values())
    assert shown == len(symbols)


def test_runner_hardware_fault_is_one_sentence(window, qtbot, tmp_path):
    pytest.importorskip("ares.scan")
    from ares.gui.runner_adapter import RunnerJob

    window.set_job_factory(lambda: RunnerJob(PTC_SMALL, faults={"disconnect_after_frames": 6}), PTC_SMALL)
    window.controls.output.write_run.setChecked(False)
    run_to_end(qtbot, window)
    assert window.session.progress.state == P.FAILED
    assert window.last_error == "sim grabber: device disconnected after 6 frames."
    assert window.error_box.text() == window.last_error


def test_broken_scan_file_is_one_sentence_with_line(window):
    pytest.importorskip("ares.protocol")
    bad = os.path.join(FIXTURES, "broken", "unknown_register.xml")
    assert not window.load_scan(bad)
    msg = window.last_error
    assert "unknown_register.xml" in msg and "\n" not in msg and "Traceback" not in msg
    assert window.scan_path is None  # the previous (demo) scan stays loaded


def test_event_pump_keeps_only_the_newest_preview_between_barriers(qtbot):
    from ares.gui.worker import EventPump

    pump = EventPump()
    pump.interval_s = pump.progress_interval_s = 0.0  # no time decimation here: only the coalescing
    got = []
    pump.event.connect(got.append)
    img = np.zeros((2, 2), np.uint16)
    pump.push(E.StageStarted(1, 2, "a", 3))
    for f in (1, 2, 3):
        pump.push(E.FramePreview(1, f, 3, img))
        pump.push(E.Progress(1, 2, f / 6))
    pump.push(E.StageResult(1, "a", img.astype(float), img.astype(float)))
    pump.push(E.FramePreview(2, 1, 3, img))
    pump.drain()
    kinds = [(type(e).__name__, getattr(e, "frame", None)) for e in got]
    assert kinds == [("StageStarted", None), ("FramePreview", 3), ("Progress", None), ("StageResult", None),
                     ("FramePreview", 1)]
    assert pump.dropped == 4


def test_time_remaining_counts_down_from_when_the_engine_computed_it():
    """Progress waits up to ``PROGRESS_INTERVAL_S`` (and the window's own work) before it
    is shown: the time remaining shown is the engine's less that wait."""
    from ares.gui.models.session import SessionModel

    s = SessionModel()
    s.clock = lambda: 101.0  # a fake clock: the event was computed at 100.0, shown 1 s later
    s.handle(E.Progress(3, 26, 0.1, 5.0, at=100.0))
    assert s.progress.seconds_remaining == 4.0
    s.handle(E.Progress(3, 26, 0.1, 0.5, at=100.0))
    assert s.progress.seconds_remaining == 0.0
    s.handle(E.Progress(3, 26, 0.1, None))
    assert s.progress.seconds_remaining is None


def test_event_pump_draws_previews_at_most_every_interval(qtbot):
    """Time decimation on a fake clock: a preview that comes too soon waits for a later
    poll when it is the newest, and is dropped when a newer stage event follows it."""
    from ares.gui.worker import EventPump

    pump = EventPump()
    now = [100.0]
    pump.clock = lambda: now[0]
    pump.interval_s = pump.progress_interval_s = 0.25
    got = []
    pump.event.connect(got.append)
    img = np.zeros((2, 2), np.uint16)
    pump.push(E.FramePreview(1, 1, 9, img))
    pump.drain()  # the first one is drawn at once
    pump.push(E.FramePreview(1, 2, 9, img))
    pump.push(E.Progress(1, 2, 0.1))
    now[0] += 0.1
    pump.drain()  # too soon: frame 2 waits, the progress goes through
    assert [(type(e).__name__, getattr(e, "frame", None)) for e in got] == [("FramePreview", 1), ("Progress", None)]
    now[0] += 0.2
    pump.drain()  # 0.3 s after the last drawn preview: frame 2 now
    assert got[-1].frame == 2
    pump.push(E.FramePreview(1, 3, 9, img))
    pump.push(E.StageResult(1, "a", img.astype(float), img.astype(float)))
    now[0] += 0.1
    pump.drain()  # too soon and superseded by the stage result: dropped
    assert type(got[-1]).__name__ == "StageResult" and pump.dropped == 1
    pump.push(E.Progress(1, 2, 0.4))
    pump.drain()  # 0.4 s after the last progress: drawn
    assert got[-1].fraction == 0.4
    n = len(got)
    pump.push(E.Progress(1, 2, 0.5))
    now[0] += 0.1
    pump.drain()  # progress too, at most every interval: this one waits ...
    assert len(got) == n
    now[0] += 0.2
    pump.drain()  # ... and comes at a later poll
    assert got[-1].fraction == 0.5


def test_check_display_passes_offscreen():
    from ares.gui.app import check_display

    check_display()  # QT_QPA_PLATFORM=offscreen: Qt starts, no exception


def test_photon_transfer_scan_fills_defect_counts_and_information(window, qtbot, tmp_path):
    pytest.importorskip("ares.scan")
    from ares.gui.runner_adapter import RunnerJob

    path = os.path.join(os.path.dirname(__file__), os.pardir, "scans", "photon_transfer.xml")
    if not os.path.isfile(path):
        pytest.skip("scans/photon_transfer.xml not present")
    from ares.protocol.scan import Output

    no_pdf = Output(raw_frames=False, hdf5=True, csv=True, pdf=False)  # the scan's outputs but the PDF (not read)
    window.set_job_factory(lambda: RunnerJob(path, frames=3, output=no_pdf), path)
    window.controls.output.directory.setText(str(tmp_path))
    run_to_end(qtbot, window)
    s = window.session
    assert s.progress.state == P.DONE, s.progress.message
    names = [r.name for r in s.defects.rows]
    assert "hot" in names and "dead" in names
    # the engine's order (a class not tested is in its place, not below "total" out of view)
    assert names == [k for k in ("stuck", "rts", "hot", "warm", "noisy", "dead", "low_response", "high_response",
                                 "unclassified", "bad_columns", "bad_rows", "clusters", "total") if k in names], names
    assert names[-1] == "total"
    show_tab(window, "Defect Counts")
    table = window.defects.table
    assert table.rowCount() == len(names) and table.item(0, 0).text() == names[0]
    assert s.defects.caption.startswith("Scan-level defect classification")
    rows = {r.name: r for r in s.defects.rows}
    # hot is a dark rate: the main job's 10 ms dark cannot show it (issue 34), and the row says
    # what it needs instead of a count; dead is tested, its rule filled with the scan's thresholds
    assert rows["hot"].count is None and rows["hot"].criterion.startswith("not available: needs an exposure >= ")
    assert table.item(names.index("hot"), 1).text() == "n/a"
    assert rows["dead"].criterion.startswith("flat response < 0.5 x")
    assert rows["noisy"].count is None and rows["noisy"].criterion.startswith("not available: ")  # 3 frames
    assert table.item(names.index("noisy"), 1).text() == "n/a"
    # the defect map over the live image and the signal map, one colour per class
    assert window.preview.overlay_items == [] and window.defects.overlay.isEnabled()
    window.defects.overlay.setChecked(True)
    drawn = {i.name(): len(i.data) for i in window.preview.overlay_items}
    assert "hot" not in drawn and drawn["dead"] == rows["dead"].count
    assert len(window.signal_map.overlay_items) == len(window.preview.overlay_items)
    window.defects.overlay.setChecked(False)
    assert window.preview.overlay_items == []
    assert "PTC: conversion gain (charge to voltage)" in s.info.items and "defect thresholds" in s.info.items
    # the stages rewritten once a flat completed the defect mask replaced their points
    pts = s.ptc.by_view["full"]
    assert len({p.stage for p in pts}) == len(pts) == sum(not r.dark for r in s.stages.results.values())
    show_tab(window, "PTC")
    caption = window.ptc.caption.text()  # the fitted gain with its SE, as the engine states it
    assert "system gain K = " in caption and "±" in caption and "DN/e-" in caption
    assert s.info.items["scan"] == path

    # Tunable thresholds: re-classify the finished run from its directory alone.
    view = window.defects
    counts = {r.name: r.count for r in s.defects.rows}
    view.reclassify()  # unchanged thresholds reproduce the scan's counts
    assert {r.name: r.count for r in s.defects.rows} == counts
    assert counts.get("dead", 0) > 0, counts
    # the simulator's dead pixels respond 0.3 of their neighbours: below 0.1 they are low-response
    view.set_threshold("dead_fraction", "0.1")
    qtbot.mouseClick(view.reclassify_button, Qt.MouseButton.LeftButton)
    after = {r.name: r.count for r in s.defects.rows}
    assert after["dead"] < counts["dead"] and after["low_response"] > counts["low_response"], (counts, after)
    assert "dead_fraction = 0.1" in s.defects.caption
    view.set_threshold("warm_z", "many")  # a bad value: one sentence, counts kept
    view.reclassify()
    assert "warm_z" in (window.last_error or "") and "\n" not in window.last_error
    assert {r.name: r.count for r in s.defects.rows} == after


def test_distributions_follow_region_changes(window, qtbot):
    window.set_job_factory(tiny())
    regions = window.session.regions
    regions.add(Region(True, True, 0, 0, 4, 4))
    show_tab(window, "Pixel Distributions")
    run_to_end(qtbot, window)
    assert set(window.distributions.plots) == {0}
    regions.add(Region(True, False, 4, 4, 5, 5))  # a new region: the tab rebuilds, old views unsubscribe
    assert set(window.distributions.plots) == {0, 1}
    assert window.session.distributions[1].counts.sum() == 25
    regions.update(0, on=False)
    assert set(window.distributions.plots) == {1}
    run_to_end(qtbot, window)  # models update again without touching deleted widgets
    assert window.session.distributions[1].counts.sum() == 25


def test_two_axis_sweep_fills_the_sweep_map(window, qtbot, tmp_path):
    pytest.importorskip("ares.scan")
    assert window.load_scan(os.path.join(FIXTURES, "small", "bias_small.xml"))
    window.controls.output.write_run.setChecked(False)
    run_to_end(qtbot, window)
    m = window.session.sweep
    assert window.session.progress.state == P.DONE, window.session.progress.message
    assert m.ndim == 2 and m.grid().shape == (3, 2) and np.isfinite(m.grid()).all()
    assert [name for name, _ in m.axes()] == ["sf_bias (V)", "tx_low (V)"]  # units from the register map
    assert "Pt: pixel temporal variance (read), DN^2" in m.quantities
    assert "image lag (%)" in m.quantities  # dark="after": every point is a bright->dark cycle
    show_tab(window, "Sweep Map")
    assert window.sweep.stack.currentWidget() is window.sweep.map_plot
    assert window.sweep.map_image.image.shape == (3, 2)  # [axis 1 up, axis 2 across], as the PDF
    window.sweep.quantity.setCurrentText("Pt: pixel temporal variance (read), DN^2")
    assert m.quantity == "Pt: pixel temporal variance (read), DN^2"


def test_drawing_a_region_on_the_live_image_edits_the_table(window, qtbot):
    regions = window.session.regions
    regions.add(Region(True, True, 2, 3, 10, 6))  # Draw ticked: handles on the live image
    regions.add(Region(True, False, 20, 20, 5, 5))  # outline only
    assert set(window.preview.rois) == {0} and window.preview.rectangle_count == 2
    roi = window.preview.rois[0]
    roi.setPos((5.0, 4.0), finish=False)
    roi.setSize((12.0, 7.0), finish=False)
    roi.sigRegionChangeFinished.emit(roi)  # what a mouse release sends
    qtbot.waitUntil(lambda: regions[0] == Region(True, True, 5, 4, 12, 7), timeout=TIMEOUT_MS)
    assert window.controls.regions.table.item(0, 2).text() == "5"
    assert window.controls.regions.table.item(0, 4).text() == "12"
    regions.update(0, draw=False)
    assert window.preview.rois == {} and window.preview.rectangle_count == 2


def test_closing_the_window_asks_then_aborts_a_running_scan(window, qtbot):
    job = start_gated(qtbot, window)
    thread = window.scan_thread
    questions = []
    window.confirm = lambda title, text: questions.append(text) or False
    window.close()  # "No": the scan goes on
    assert questions and window.isVisible() and window.running and not job.aborting
    window.confirm = lambda title, text: True
    window.close()  # "Yes": abort; the window closes when the run has ended, without blocking meanwhile
    assert job.aborting and window.isVisible()
    job.gate.set()
    qtbot.waitUntil(lambda: not window.isVisible(), timeout=TIMEOUT_MS)
    assert not thread.is_running() and idle(window)


def test_gui_command_is_registered_in_the_cli():
    from ares.cli import build_parser

    args = build_parser().parse_args(["gui", "scans/photon_transfer.xml"])
    assert args.command == "gui" and args.scan == "scans/photon_transfer.xml"


def test_roa_table_regions_are_what_the_run_analyses_and_saves(window, qtbot, tmp_path):
    """A region typed into the RoA table after loading reaches the engine: the run's stages
    are decomposed over it and the scan XML saved in the run holds it."""
    pytest.importorskip("ares.scan")
    import json

    assert window.load_scan(PTC_SMALL)
    window.session.regions.update(1, on=True, draw=False, x=2, y=3, width=10, height=8)
    window.controls.output.directory.setText(str(tmp_path))
    run_to_end(qtbot, window)
    assert window.session.progress.state == P.DONE, window.session.progress.message
    run_dir = window.session.info.items["run directory"]
    stage = json.loads(open(os.path.join(run_dir, "stages", "0001.json")).read())
    assert {"full", "centre", "roa2"} <= set(stage["views"])
    assert stage["views"]["roa2"]["level"]["n_pixels"] == 10 * 8
    saved = open(os.path.join(run_dir, "xml", "ptc_small.xml")).read()
    assert 'name="roa2" x="2" y="3" width="10" height="8"' in saved


def test_an_edited_scan_keeps_its_relative_mask_and_leaves_no_temporary_files(tmp_path):
    """Regions edited in the window make a temporary scan XML: a defect mask named relative
    to the loaded scan is still that file, and the temporary folder goes with the job."""
    pytest.importorskip("ares.scan")
    import json
    from pathlib import Path

    from ares.gui.runner_adapter import RunnerJob

    sys_xml = os.path.abspath(os.path.join(FIXTURES, "small", "sim_small.xml"))
    text = open(PTC_SMALL).read().replace('href="sim_small.xml"', f'href="{sys_xml}"')
    text = text.replace("</analyses>", '</analyses>\n  <defects mask="masks/m.npy"/>')
    (tmp_path / "masks").mkdir()
    (tmp_path / "scan.xml").write_text(text)
    m = np.zeros((24, 32), bool)  # sim_small's array
    m[3, 5] = True
    np.save(tmp_path / "masks" / "m.npy", m)
    job = RunnerJob(tmp_path / "scan.xml", frames=3, regions=[(0, Region(on=True, x=2, y=3, width=10, height=8))])
    edited = Path(job.scan.source).parent
    assert edited != tmp_path and edited.is_dir()
    assert job.scan.defect_mask == str(tmp_path / "masks" / "m.npy")
    job.discard()  # a job that never runs (Start refused) removes its folder too
    assert not edited.exists()

    job = RunnerJob(tmp_path / "scan.xml", frames=3, regions=[(0, Region(on=True, x=2, y=3, width=10, height=8))])
    job.set_output(str(tmp_path / "runs"))
    edited = Path(job.scan.source).parent
    job.run(lambda ev: None)
    assert not edited.exists()
    run_dir = next((tmp_path / "runs").iterdir())
    stage = json.loads((run_dir / "stages" / "0001.json").read_text())
    assert stage["defect_mask"]["masked_pixels"] == 1
    assert 'mask="' + str(tmp_path / "masks" / "m.npy") + '"' in (run_dir / "xml" / "scan.xml").read_text()


def _two_adc_scan(tmp_path, offset_dn: float = 40.0):
    """A dark scan on the small simulated sensor with two column-interleaved ADCs whose
    offsets differ by ``offset_dn``: the full frame's mean-signal histogram has two peaks."""
    system = open(os.path.join(FIXTURES, "small", "sim_small.xml")).read().replace(
        '<param name="hot_rate_ppm" type="float" value="0"/>',
        f'<param name="hot_rate_ppm" type="float" value="0"/>\n'
        f'    <param name="adc_offset_dn" type="floats" value="0 {offset_dn:g}"/>')
    (tmp_path / "sim_2adc.xml").write_text(system)
    (tmp_path / "dark_2adc.xml").write_text(
        '<scan name="dark_2adc" version="1"><system href="sim_2adc.xml"/><frames>8</frames>'
        '<stages><stage name="dark" scene="dark"/><stage name="dark2" scene="dark"/></stages>'
        '<analyses><analysis name="decomposition"/></analyses></scan>')
    return str(tmp_path / "dark_2adc.xml")


def test_channel_view_on_a_two_adc_sensor_gives_the_per_channel_sigma(window, qtbot, tmp_path):
    pytest.importorskip("ares.scan")
    assert window.load_scan(_two_adc_scan(tmp_path))
    window.controls.output.directory.setText(str(tmp_path / "runs"))
    keys = [window.view_bar.view.itemData(i) for i in range(window.view_bar.view.count())]
    assert {"full", "adc0", "adc1"} <= set(keys)
    run_to_end(qtbot, window)
    s = window.session
    assert s.progress.state == P.DONE, s.progress.message
    window.view_bar.choose_view("full")
    mean = s.last_result.mean.astype(np.float64)
    full_sigma = s.panels["MEAN SIGNAL"].stats.fitted_sigma
    for k in (0, 1):
        window.view_bar.choose_view(f"adc{k}")
        st = s.panels["MEAN SIGNAL"].stats
        channel = mean[:, k::2]
        assert st.n == channel.size
        assert st.sigma == pytest.approx(channel.std(ddof=1), rel=1e-6)  # every pixel of the channel, no other
        assert st.fitted_sigma == pytest.approx(channel.std(ddof=1), rel=0.3)  # one peak: the fit finds it
        assert st.fitted_sigma < full_sigma / 3  # the full frame's two peaks 40 DN apart
        assert window.components.model.view == f"adc{k}"  # the engine's decomposition of the same pixels
        show_tab(window, "Components")
        assert window.components.tables["components"].rowCount() > 0
        show_tab(window, "Results")
        assert window.results.caption.text().endswith(s.views.labels[f"adc{k}"])
    # the stage browser: the first stage on every tab, then back to following the scan
    show_tab(window, "Signal Map")
    window.view_bar.choose_stage(0)
    assert s.last_result.stage == 0 and "stage 0" in s.signal_map.caption
    window.view_bar.choose_stage(None)
    assert s.last_result.stage == 1


def test_register_written_in_the_instrumentation_tab_reaches_the_bench(window, qtbot):
    pytest.importorskip("ares.scan")
    system = os.path.join(FIXTURES, "small", "sim_small.xml")
    tab = window.controls.instruments
    tab.path.setText(system)
    tab.choose(system)
    qtbot.mouseClick(tab.connect_button, Qt.MouseButton.LeftButton)
    assert tab.model.connected and tab.connect_button.text() == "Disconnect"
    names = [tab.fields.item(r, 0).text() for r in range(tab.fields.rowCount())]
    row = names.index("black_level")
    assert tab.fields.item(row, 3).text() == "0 .. 4095"  # the register map's limits
    assert not tab.fields.item(names.index("chip_id"), 1).flags() & Qt.ItemFlag.ItemIsEditable  # read-only
    before = tab.model.grab().astype(float).mean()
    tab.fields.item(row, 1).setText("300")  # what typing a value into the cell does
    assert tab.model.bench.registers.get("black_level") == 300  # reached the bench's register file ...
    frames = []
    tab.frame.connect(frames.append)
    qtbot.mouseClick(tab.grab_button, Qt.MouseButton.LeftButton)
    assert frames and frames[0].astype(float).mean() == pytest.approx(before + 300 - 64, abs=2)  # ... and the sensor
    assert window.session.preview.caption == "test frame from the bench"
    assert tab.fields.item(row, 1).text() == "300"  # read back
    tab.fields.item(row, 1).setText("5000")  # above the map's maximum: one sentence, nothing written
    assert window.last_error == "register field 'black_level': 5000 DN is above its maximum 4095"
    assert tab.model.bench.registers.get("black_level") == 300 and tab.fields.item(row, 1).text() == "300"
    tab.light.setValue(1500)
    qtbot.mouseClick(tab.light_button, Qt.MouseButton.LeftButton)
    tab.chamber.setValue(31.5)
    qtbot.mouseClick(tab.chamber_button, Qt.MouseButton.LeftButton)
    assert tab.model.bench.light.get_level() == 1500 and tab.model.bench.chamber.get_temperature() == 31.5
    assert "chamber: 31.50 °C" in tab.status.text()
    # the next scan runs on the chosen system and opens the devices itself
    assert window.load_scan(PTC_SMALL)
    window.controls.output.write_run.setChecked(False)
    run_to_end(qtbot, window)
    assert not tab.model.connected and window.session.progress.state == P.DONE


def _drag(qtbot, plot, start, end):
    """A left-button mouse drag on a pyqtgraph plot between two image points."""
    from PySide6.QtCore import QPoint, QPointF
    from PySide6.QtGui import QMouseEvent
    from PySide6.QtWidgets import QApplication

    vb = plot.getViewBox()

    def at(p):
        return plot.mapFromScene(vb.mapViewToScene(QPointF(*p)))

    vp = plot.viewport()
    a, b = at(start), at(end)
    steps = [QPoint(a.x() + (b.x() - a.x()) * k // 8, a.y() + (b.y() - a.y()) * k // 8) for k in range(1, 9)]
    left, none = Qt.MouseButton.LeftButton, Qt.MouseButton.NoButton
    send = QApplication.sendEvent
    send(vp, QMouseEvent(QMouseEvent.Type.MouseButtonPress, QPointF(a), QPointF(vp.mapToGlobal(a)), left, left,
                         Qt.KeyboardModifier.NoModifier))
    for p in steps:
        send(vp, QMouseEvent(QMouseEvent.Type.MouseMove, QPointF(p), QPointF(vp.mapToGlobal(p)), none, left,
                             Qt.KeyboardModifier.NoModifier))
    send(vp, QMouseEvent(QMouseEvent.Type.MouseButtonRelease, QPointF(b), QPointF(vp.mapToGlobal(b)), left, none,
                         Qt.KeyboardModifier.NoModifier))


def test_region_drawn_with_the_mouse_is_saved_and_decomposed(window, qtbot, tmp_path):
    """New Region + a mouse drag on the live image adds a row to the RoA table; the run
    saves it in its scan XML and decomposes its pixels (other figures than the full frame)."""
    pytest.importorskip("ares.scan")
    import json

    assert window.load_scan(PTC_SMALL)
    window.controls.output.directory.setText(str(tmp_path))
    window.show_image(np.zeros((24, 32), np.uint16), "blank")  # the image the drag is drawn on
    qtbot.mouseClick(window.preview.new_button, Qt.MouseButton.LeftButton)
    _drag(qtbot, window.preview.plot, (2.2, 3.1), (13.8, 17.2))
    regions = window.session.regions
    qtbot.waitUntil(lambda: len(regions.active()) == 2, timeout=TIMEOUT_MS)
    row, drawn = regions.active()[1]
    assert (drawn.x, drawn.y, drawn.width, drawn.height) == (2, 3, 12, 14) and drawn.draw
    assert not window.preview.new_button.isChecked()  # one region per click
    run_to_end(qtbot, window)
    assert window.session.progress.state == P.DONE, window.session.progress.message
    run_dir = window.session.info.items["run directory"]
    saved = open(os.path.join(run_dir, "xml", "ptc_small.xml")).read()
    assert f'name="roa{row + 1}" x="2" y="3" width="12" height="14"' in saved
    stage = json.loads(open(os.path.join(run_dir, "stages", "0005.json")).read())
    mine, full = stage["views"][f"roa{row + 1}"], stage["views"]["full"]
    assert mine["level"]["n_pixels"] == 12 * 14
    assert mine["components"]["Pt"]["value"] != full["components"]["Pt"]["value"]
    assert mine["components"]["Pt"]["se"] > full["components"]["Pt"]["se"]  # fewer pixels, larger SE


def test_input_images_are_analysed_as_ares_analyze_does(window, qtbot, tmp_path):
    """A folder of PNG frames and a dark .npy stack, through the Input Images tab: the
    Components tab holds exactly what `ares analyze --json` prints for the same files."""
    import json
    import subprocess
    import sys

    from PIL import Image

    rng = np.random.default_rng(5)
    prnu = 1 + 0.01 * rng.standard_normal((20, 24))
    flats = tmp_path / "flats"
    flats.mkdir()
    for k in range(6):
        frame = 100 + rng.poisson(800 * prnu) * 0.5 + rng.normal(0, 2, (20, 24))
        Image.fromarray(np.rint(frame).astype(np.uint16)).save(flats / f"f{k:02d}.png")
    darks = 100 + rng.normal(0, 2, (6, 20, 24))
    np.save(tmp_path / "dark.npy", np.rint(darks).astype(np.uint16))
    tab = window.controls.inputs
    tab.inputs.setText(str(flats))
    tab.darks.setText(str(tmp_path / "dark.npy"))
    qtbot.mouseClick(tab.analyse_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: idle(window), timeout=TIMEOUT_MS)
    s = window.session
    assert s.progress.state == P.DONE, s.progress.message
    assert [r.name for r in s.stages.results.values()] == ["dark", "flat"]
    cli = subprocess.run([sys.executable, "-m", "ares.cli", "analyze", str(flats), "--dark", str(tmp_path / "dark.npy"),
                          "--json"], capture_output=True, text=True, check=True)
    want = json.loads(cli.stdout)
    got = s.last_result.components["full"]["components"]
    for k in ("o", "Pt", "Ps", "Rt", "Ct", "G", "Pg", "q"):
        assert got[k] == want[k], k  # the same numbers, SEs and verdicts
    assert want["Pt"]["value"] == pytest.approx(4 + 1 / 12, rel=0.15)  # 2 DN read noise + quantization
    show_tab(window, "Components")
    assert window.components.tables["components"].rowCount() >= 13
    assert s.last_result.mean.shape == (20, 24) and s.panels["MEAN SIGNAL"].stats.n == 20 * 24
    tab.inputs.setText(str(tmp_path / "missing"))  # a bad path: one sentence naming it
    qtbot.mouseClick(tab.analyse_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: idle(window), timeout=TIMEOUT_MS)
    assert "missing" in window.last_error and "\n" not in window.last_error


def test_window_fits_a_1280x800_screen(window):
    assert window.load_scan(PTC_SMALL)
    hint = window.minimumSizeHint()
    assert hint.width() <= 1280 and hint.height() <= 800, hint
    window.resize(1280, 800)
    assert window.width() <= 1280 and window.height() <= 800


def test_loading_a_scan_asks_before_replacing_edited_regions(window, tmp_path):
    assert window.load_scan(PTC_SMALL)  # its region "centre" fills row 1
    regions = window.session.regions
    regions.update(0, x=1, y=1, width=5, height=5)  # edited by hand
    asked = []
    window.confirm = lambda title, text: asked.append(text) or False
    assert window.load_scan(PTC_SMALL)
    assert asked and (regions[0].x, regions[0].width) == (1, 5)  # "No": the table is kept
    assert "keeps your regions" in window.statusBar().currentMessage()
    window.confirm = lambda title, text: asked.append(text) or True
    assert window.load_scan(PTC_SMALL)
    assert len(asked) == 2 and (regions[0].x, regions[0].width) == (8, 16)  # "Yes": the scan's region
    assert window.load_scan(PTC_SMALL) and len(asked) == 2  # nothing edited since: no question
