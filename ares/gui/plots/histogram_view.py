"""Histogram view of a ``StatsPanelModel`` (bars over From..To + the fitted Gaussian)."""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg

from ares.gui.models.stats import StatsPanelModel
from ares.gui.plots import plain_axes


def gaussian_curve(model: StatsPanelModel, points: int = 200):
    s = model.stats
    if not (math.isfinite(s.fitted_mean) and math.isfinite(s.fitted_sigma)) or s.fitted_sigma <= 0:
        return None
    width = float(np.diff(model.edges).mean()) if model.edges.size > 1 else 1.0
    x = np.linspace(model.edges[0], model.edges[-1], points)
    area = float(model.counts.sum()) * width
    y = area / (s.fitted_sigma * math.sqrt(2 * math.pi)) * np.exp(-0.5 * ((x - s.fitted_mean) / s.fitted_sigma) ** 2)
    return x, y


class HistogramPlot(pg.PlotWidget):
    def __init__(self, model: StatsPanelModel, color=(30, 120, 220), xlabel: str = "DN", parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.setLabel("bottom", xlabel)
        self.setLabel("left", "pixels")
        plain_axes(self)
        self.bars = pg.PlotDataItem(stepMode="center", fillLevel=0, brush=(*color, 90), pen=pg.mkPen(color))
        self.fit = pg.PlotDataItem(pen=pg.mkPen((200, 0, 0), width=1.5))
        self.addItem(self.bars)
        self.addItem(self.fit)
        self.unsubscribe = model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        m = self.model
        if m.counts.size and m.counts.sum() > 0:
            self.bars.setData(m.edges, m.counts.astype(float))
            curve = gaussian_curve(m)
            if curve is None:
                self.fit.setData([], [])
            else:
                self.fit.setData(*curve)
            self.setXRange(m.range[0], m.range[1], padding=0)
            self.enableAutoRange(axis="y")
        else:
            self.bars.setData([], [])
            self.fit.setData([], [])
