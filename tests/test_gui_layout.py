"""The window at 1280x800 (issue 38): every plot of every result tab in view (the PTC tab
showed 0-300 DN of its curve with the rest behind a scrollbar, the Results panels were
cut), long "n/a (reason)" texts elided with the whole text in a tooltip rather than
pushing the Unit column off-screen, every control tab's name and the run's state whole,
and a sensible "Current Stage" when idle."""

from __future__ import annotations

import math
import os

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from test_gui import PTC_SMALL, run_to_end, show_tab, window  # noqa: E402,F401 (fixture)

from ares.gui.main_window import RESULT_TABS  # noqa: E402
from ares.gui.models import progress as P  # noqa: E402

pytestmark = pytest.mark.gui
MIN_VISIBLE = 0.95  # of each plot's area in view at 1280x800


def visible_fraction(widget) -> float:
    """The share of ``widget``'s area inside the window and every ancestor it is in (a
    scroll area's viewport clips what lies beyond it)."""
    from PySide6.QtCore import QPoint, QRect

    top = widget.window()
    rect = QRect(widget.mapTo(top, QPoint(0, 0)), widget.size())
    area = rect.width() * rect.height()
    parent = widget.parentWidget()
    while parent is not None:
        rect = rect.intersected(QRect(parent.mapTo(top, QPoint(0, 0)), parent.size()) if parent is not top
                                else QRect(QPoint(0, 0), top.size()))
        parent = parent.parentWidget()
    return rect.width() * rect.height() / area if area else 0.0


def settle(qtbot, window) -> None:
    from PySide6.QtWidgets import QApplication

    for _ in range(3):
        QApplication.processEvents()
    qtbot.waitExposed(window)


def test_every_plot_fits_1280x800_and_the_ptc_shows_its_whole_curve(window, qtbot, tmp_path):  # noqa: F811
    import pyqtgraph as pg

    from ares.gui.runner_adapter import RunnerJob
    from ares.protocol.scan import Output

    window.resize(1280, 800)
    window.controls.output.directory.setText(str(tmp_path))
    quick = Output(raw_frames=False, hdf5=False, csv=False, pdf=False)  # the window's figures, no reports
    window.set_job_factory(lambda: RunnerJob(PTC_SMALL, frames=3, output=quick), PTC_SMALL)
    run_to_end(qtbot, window)
    assert window.width() <= 1280 and window.height() <= 800
    from ares.gui.models.sweep import SweepPoint

    for k in range(20):  # and a 2-D sweep with long axis names (its caption widened the Sweep Map)
        i, j = divmod(k, 4)
        window.session.sweep.add(SweepPoint(100 + k, "a_two_axis_bias_map", (i, j),
                                            {"reg:source_follower_bias": 1.0 + i, "reg:transfer_gate_low": -j / 5},
                                            {"image lag (%)": 0.01 * k}))
    plots = 0
    for name in RESULT_TABS:
        show_tab(window, name)
        settle(qtbot, window)
        page = window.result_tabs.currentWidget()
        assert not page.horizontalScrollBar().isVisible(), f"{name}: wider than the window"
        for view in page.findChildren(pg.GraphicsView):
            if view.isVisible():
                plots += 1
                assert visible_fraction(view) >= MIN_VISIBLE, (name, visible_fraction(view))
    assert plots >= 10

    show_tab(window, "PTC")
    settle(qtbot, window)
    x, y = window.session.ptc.xy()
    ok = (x > 0) & (y > 0)
    assert ok.sum() >= 5
    (x0, x1), (y0, y1) = window.ptc.plot.getViewBox().viewRange()  # log10 units in log mode
    assert x0 <= math.log10(x[ok].min()) and x1 >= math.log10(x[ok].max()), (x0, x1, x[ok].min(), x[ok].max())
    assert y0 <= math.log10(y[ok].min()) and y1 >= math.log10(y[ok].max())

    # Components: the Unit column in view; an elided "n/a (reason)" whole in its tooltip
    show_tab(window, "Components")
    settle(qtbot, window)
    table = window.components.tables["components"]
    head = table.horizontalHeader()
    unit = window.components.HEADERS.index("Unit")
    assert head.sectionViewportPosition(unit) + head.sectionSize(unit) <= table.viewport().width()
    col = window.components.HEADERS.index("Estimate ± SE")
    texts = [table.item(r, col) for r in range(table.rowCount())]
    assert texts and all(item.toolTip() == item.text() for item in texts)


def test_control_tab_names_state_and_idle_stage_are_whole_at_1280x800(window, qtbot):  # noqa: F811
    window.resize(1280, 800)
    settle(qtbot, window)
    line = window.progress_line
    assert line.stage.text() == P.IDLE_TEXT and "0 0" not in line.stage.shown_text()
    bar = window.controls.tabBar()
    need = sum(bar.tabSizeHint(i).width() for i in range(bar.count()))
    assert need <= bar.width(), (need, bar.width())  # no tab behind scroll buttons, none cut
    long_name = "a stage with a rather long name[124] at 45 degC"
    window.session.progress.update(stage=124, total=400, stage_name=long_name, state=P.FINISHING)
    settle(qtbot, window)
    fm = line.state.fontMetrics()
    assert line.state.text() == P.FINISHING and line.state.width() >= fm.horizontalAdvance(P.FINISHING)
    assert visible_fraction(line.state) == 1.0
    assert long_name in line.stage.toolTip()  # elided if need be, whole in the tooltip
    assert visible_fraction(line.stage) == 1.0
    window.session.progress.reset()
