"""Readable axes (issue 38): the Sweep Map's colour bars had no tick labels for G and PRNU
(ranges like 0.27990..0.27998 or 1e-4 wide) and one for the row/column gain maps; log
axes' labels overlapped during a scan. Checked on what pyqtgraph would draw (the axis'
draw specs), not on the tick values alone."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

pytestmark = pytest.mark.gui

RANGES = [(0.27990, 0.27998), (1e-4, 2e-4), (0.0, 1e-4), (3.0, 3.0001), (0.2, 4000.0), (1e-6, 1.5e-6),
          (-0.01, 0.02), (0.5, 50.0), (-3e5, 7e5), (0.9995, 1.0004)]


def drawn(axis):
    """(rectangle, text) of every tick label the axis draws, once its window is rendered."""
    from PySide6.QtGui import QImage, QPainter
    from PySide6.QtWidgets import QApplication

    QApplication.processEvents()
    axis.scene().views()[0].window().grab()  # laid out and painted as on screen

    img = QImage(10, 10, QImage.Format.Format_ARGB32)
    p = QPainter(img)
    try:
        specs = axis.generateDrawSpecs(p)
    finally:
        p.end()
    return [(t[0], t[2]) for t in (specs[2] if specs else []) if t[2]]


def no_overlap(texts) -> bool:
    return not any(a.intersects(b) for i, (a, _) in enumerate(texts) for b, _ in texts[i + 1:])


@pytest.mark.parametrize("lo, hi", RANGES)
def test_nice_ticks_are_three_or_more_distinct_labels_within_the_range(lo, hi):
    from ares.gui.plots import nice_ticks

    ticks = nice_ticks(lo, hi)
    assert 3 <= len(ticks) <= 9, ticks
    values = [v for v, _ in ticks]
    labels = [t for _, t in ticks]
    step = values[1] - values[0]
    assert all(lo - 1e-12 * abs(hi) <= v <= hi + 1e-12 * abs(hi) for v in values)
    assert len(set(labels)) == len(labels)
    assert all(abs(float(t) - v) <= step / 2 for v, t in ticks)  # each label reads as its value


def _shown(qtbot, view, width: int, height: int):
    qtbot.addWidget(view)
    view.resize(width, height)
    view.show()
    qtbot.waitExposed(view)
    return view


def _sweep_map(qtbot, lo, hi):
    from ares.gui.models.sweep import SweepModel, SweepPoint
    from ares.gui.plots.sweep_view import SweepView

    m = SweepModel()
    view = _shown(qtbot, SweepView(m), 790, 640)
    k = 0
    for i in range(4):
        for j in range(3):
            k += 1
            m.add(SweepPoint(k, "g", (i, j), {"a": float(i), "b": float(j)},
                             {"G: conversion gain, DN/e-": lo + (hi - lo) * (k - 1) / 11}))
    qtbot.waitExposed(view)
    return view


@pytest.mark.parametrize("lo, hi", RANGES)
def test_sweep_map_colour_bar_draws_three_or_more_labels(qtbot, lo, hi):
    view = _sweep_map(qtbot, lo, hi)
    texts = drawn(view.colorbar.axis)
    assert len(texts) >= 3, texts
    assert no_overlap(texts)
    axis = view.colorbar.axis  # every label inside the bar's axis (none clipped)
    assert all(r.width() <= axis.width() for r, _ in texts), (axis.width(), texts)


def test_image_colour_bar_draws_three_or_more_labels_for_a_tiny_range(qtbot):
    from ares.gui.models.image import ImageModel
    from ares.gui.plots.image_view import ImagePlot

    m = ImageModel("prnu map")
    view = _shown(qtbot, ImagePlot(m), 500, 400)
    m.set_image(1.0 + 1e-4 * np.random.default_rng(1).standard_normal((40, 50)), "tiny")
    qtbot.waitExposed(view)
    texts = drawn(view.colorbar.axis)
    assert len(texts) >= 3, texts


@pytest.mark.parametrize("width", [400, 790])
def test_log_axes_labels_never_overlap_as_a_scan_adds_points(qtbot, width):
    from ares.gui.models.ptc import PTCModel
    from ares.gui.models.sweep import SweepModel, SweepPoint
    from ares.gui.plots.ptc_view import PTCView
    from ares.gui.plots.sweep_view import SweepView

    m = PTCModel()
    view = _shown(qtbot, PTCView(m), width, 500)
    x = 2.0 * 1.4 ** np.arange(24)
    for n in range(24):  # the PTC as a scan fills it, level by level
        m.add(n, f"ptc[{n}]", x[n], x[n] / 3.57)
        for side in ("bottom", "left"):
            texts = drawn(view.plot.getAxis(side))
            assert no_overlap(texts), (n, side, [t for _, t in texts])
    assert len(drawn(view.plot.getAxis("bottom"))) >= 3

    s = SweepModel()
    sweep = _shown(qtbot, SweepView(s), width, 500)
    for i, e in enumerate([0.001, 0.002, 0.005, 0.01, 0.03, 0.1, 0.3, 1.0]):  # exposure over three decades
        s.add(SweepPoint(i, "g", (i,), {"exposure": e}, {"mean signal (DN)": 10 * e}))
    texts = drawn(sweep.curve_plot.getAxis("bottom"))
    assert len(texts) >= 3 and no_overlap(texts), [t for _, t in texts]
