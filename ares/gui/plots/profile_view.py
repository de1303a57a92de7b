"""Row and column profiles of each active region, one colour per region."""

from __future__ import annotations

import pyqtgraph as pg
from PySide6.QtWidgets import QVBoxLayout, QWidget

from ares.gui.models.profiles import ProfilesModel
from ares.gui.plots import plain_axes, region_color


class ProfilesView(QWidget):
    def __init__(self, model: ProfilesModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.columns = pg.PlotWidget(title="Column profile (mean over rows)")
        self.rows = pg.PlotWidget(title="Row profile (mean over columns)")
        self.columns.setLabel("bottom", "column")
        self.rows.setLabel("bottom", "row")
        for p in (self.columns, self.rows):
            p.setLabel("left", "mean output (offset included)", units="DN")
            p.addLegend(offset=(-10, 10))
            plain_axes(p)
        lay = QVBoxLayout(self)
        lay.addWidget(self.columns)
        lay.addWidget(self.rows)
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        for plot, curves in ((self.columns, self.model.columns), (self.rows, self.model.rows)):
            plot.clear()
            for i, prof in sorted(curves.items()):
                name = "full frame" if i < 0 else f"region {i + 1}"
                plot.plot(prof.x, prof.y, pen=pg.mkPen(region_color(i), width=1.5), name=name)
