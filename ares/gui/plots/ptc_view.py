"""Photon transfer curve: temporal variance vs signal above dark, log-log."""

from __future__ import annotations

import math

import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from ..models.ptc import PTCModel
from . import plain_axes


class PTCView(QWidget):
    def __init__(self, model: PTCModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.plot = pg.PlotWidget(title="Photon transfer curve")
        self.plot.setLogMode(x=True, y=True)
        self.plot.setLabel("bottom", "signal above dark", units="DN")
        self.plot.setLabel("left", "temporal variance above dark", units="DN²")
        self.plot.showGrid(x=True, y=True, alpha=0.3)
        plain_axes(self.plot)
        self.points = pg.PlotDataItem(pen=None, symbol="o", symbolSize=9,
                                     symbolBrush=pg.mkBrush(30, 120, 220), symbolPen=pg.mkPen("k"))
        self.line = pg.PlotDataItem(pen=pg.mkPen((200, 0, 0), width=1.5, style=Qt.PenStyle.DashLine))
        self.plot.addItem(self.points)
        self.plot.addItem(self.line)
        self.caption = QLabel()
        lay = QVBoxLayout(self)
        lay.addWidget(self.plot, 1)
        lay.addWidget(self.caption)
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        m = self.model
        x, y = m.xy()
        ok = (x > 0) & (y > 0)
        # PlotDataItems in a log-mode plot take linear data and log it themselves
        self.points.setData(x[ok], y[ok])
        fit = m.fit_line()
        if fit is None:
            self.line.setData([], [])
        else:
            self.line.setData(*fit)
        parts = [f"{int(ok.sum())} point(s)" + (f" ({m.view} pixels, as computed by the engine)" if m.view else "")]
        if m.dark_dn is not None:
            parts.append(f"dark level {m.dark_dn:.2f} DN")
        if math.isfinite(m.gain_e_per_dn):
            parts.append(f"conversion gain {m.gain_e_per_dn:.4g} e-/DN" + (f" ({m.fit_note})" if m.fit_note else ""))
        self.caption.setText(" · ".join(parts))
