"""Sweep Map tab: an engine quantity over the scan's sweep axes (curve or 2-D map)."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtWidgets import QComboBox, QHBoxLayout, QLabel, QStackedWidget, QVBoxLayout, QWidget

from ares.gui.models.sweep import SweepModel
from ares.gui.layout import redraw_when_shown
from ares.gui.plots import DecadeAxis, plain_axes, set_colorbar_levels


class SweepView(QWidget):
    def __init__(self, model: SweepModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.quantity = QComboBox()
        self.quantity.setMinimumWidth(260)
        self.caption = QLabel()
        self.caption.setWordWrap(True)  # a long sweep description never widens the tab past the window
        top = QHBoxLayout()
        top.addWidget(QLabel("Quantity:"))
        top.addWidget(self.quantity)
        top.addWidget(self.caption, 1)
        self.curve_plot = pg.PlotWidget(axisItems={"bottom": DecadeAxis("bottom")})  # log x: decades labelled
        plain_axes(self.curve_plot)
        self.curve_plot.showGrid(x=True, y=True, alpha=0.3)
        self.curve = self.curve_plot.plot([], [], pen=pg.mkPen((30, 120, 220), width=1.5), symbol="o",
                                          symbolSize=7, symbolBrush=(30, 120, 220))
        self.map_plot = pg.PlotWidget()
        self.map_image = pg.ImageItem()
        self.map_plot.addItem(self.map_image)
        self.colorbar = pg.ColorBarItem(colorMap=pg.colormap.get("viridis"), interactive=False, width=12)
        self.colorbar.setImageItem(self.map_image, insert_in=self.map_plot.getPlotItem())
        self.stack = QStackedWidget()
        self.stack.addWidget(self.curve_plot)
        self.stack.addWidget(self.map_plot)
        lay = QVBoxLayout(self)
        lay.addLayout(top)
        lay.addWidget(self.stack, 1)
        self.quantity.currentTextChanged.connect(self._chosen)
        redraw_when_shown(self, model)
        self.refresh()

    def _chosen(self, text: str) -> None:
        if text and text != self.model.quantity:
            self.model.set_quantity(text)

    def refresh(self) -> None:
        m = self.model
        names = m.quantities
        if names != [self.quantity.itemText(i) for i in range(self.quantity.count())]:
            self.quantity.blockSignals(True)
            self.quantity.clear()
            self.quantity.addItems(names)
            self.quantity.blockSignals(False)
        if m.quantity:
            self.quantity.blockSignals(True)
            self.quantity.setCurrentText(m.quantity)
            self.quantity.blockSignals(False)
        pts = m.group_points()
        if not pts:
            self.caption.setText("No sweep yet: a scan with a <sweep> fills this map stage by stage.")
            self.curve.setData([], [])
            return
        axes = m.axes()
        view = "full frame" if m.view == "full" else f"view '{m.view}'"
        self.caption.setText(f"sweep '{pts[-1].group}', {view}: {len(pts)} stage(s) over "
                             + " × ".join(f"{name} ({len(v)})" for name, v in axes))
        if m.ndim == 1:
            self.stack.setCurrentWidget(self.curve_plot)
            x, y = m.curve()
            positive = x.size > 1 and np.all(x > 0) and x.max() / x.min() > 100
            self.curve_plot.setLogMode(x=bool(positive), y=False)
            self.curve.setData(x, y)
            self.curve_plot.setLabel("bottom", axes[0][0])
            self.curve_plot.setLabel("left", m.quantity or "")
        elif m.ndim == 2:
            self.stack.setCurrentWidget(self.map_plot)
            g = m.grid()
            finite = g[np.isfinite(g)]
            levels = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
            if levels[1] <= levels[0]:
                levels = (levels[0] - 0.5, levels[1] + 0.5)
            # as the PDF's 2-D sweep pages: the first axis (the outer sweep) up, the second across
            # -- the image (row-major) is indexed [axis 1, axis 2]
            self.map_image.setImage(g.astype(np.float32), autoLevels=False, levels=levels)
            if not np.isfinite(g).all():  # say what a blank cell is, as the PDF's panel title does
                self.caption.setText(self.caption.text() + "; blank: no value there (not available, or only a "
                                     "limit: not resolved from 0)")
            set_colorbar_levels(self.colorbar, levels)
            for side, (name, values) in zip(("left", "bottom"), axes):
                ax = self.map_plot.getAxis(side)
                ax.setTicks([[(i + 0.5, f"{v:g}") for i, v in enumerate(values)]])
                self.map_plot.setLabel(side, name)
            self.map_plot.setTitle(m.quantity or "")
            self.map_plot.getPlotItem().autoRange()
