"""Photon transfer curve: temporal variance vs signal above dark, log-log."""

from __future__ import annotations

import math

import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from ares.gui.layout import redraw_when_shown
from ares.gui.models.ptc import PTCModel
from ares.gui.plots import DecadeAxis, plain_axes


class PTCView(QWidget):
    def __init__(self, model: PTCModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.plot = pg.PlotWidget(title="Photon transfer curve",
                                 axisItems={k: DecadeAxis(k) for k in ("bottom", "left")})
        self.plot.setLogMode(x=True, y=True)
        self.plot.setLabel("bottom", "signal above dark", units="DN")
        self.plot.setLabel("left", "temporal variance above dark", units="DN²")
        self.plot.showGrid(x=True, y=True, alpha=0.3)
        plain_axes(self.plot)
        self.plot.addLegend(offset=(10, 10))
        self.sets = {  # the engine's verdict per level
            "fit": pg.PlotDataItem(pen=None, symbol="o", symbolSize=9, name="in the gain fit",
                                   symbolBrush=pg.mkBrush(30, 120, 220), symbolPen=pg.mkPen("k")),
            "valid": pg.PlotDataItem(pen=None, symbol="o", symbolSize=9, name="valid, outside the fit range",
                                     symbolBrush=pg.mkBrush(255, 255, 255), symbolPen=pg.mkPen((30, 120, 220), width=1.5)),
            "excluded": pg.PlotDataItem(pen=None, symbol="x", symbolSize=11, name="excluded (clipped, no signal...)",
                                        symbolBrush=pg.mkBrush(200, 0, 0), symbolPen=pg.mkPen((200, 0, 0))),
            "view": pg.PlotDataItem(pen=None, symbol="o", symbolSize=9, name="this view's levels (the fit is the full frame's)",
                                    symbolBrush=pg.mkBrush(120, 190, 120), symbolPen=pg.mkPen("k")),
            "pending": pg.PlotDataItem(pen=None, symbol="o", symbolSize=8, name="measured (fit after the scan)",
                                       symbolBrush=pg.mkBrush(150, 150, 150), symbolPen=pg.mkPen("k")),
        }
        self.shown = pg.PlotDataItem(pen=None, symbol="s", symbolSize=15, symbolBrush=None,
                                     symbolPen=pg.mkPen((230, 140, 0), width=2), name="stage shown")
        self.line = pg.PlotDataItem(pen=pg.mkPen((200, 0, 0), width=1.5, style=Qt.PenStyle.DashLine),
                                    name="shot-noise line of the fitted K")
        for item in (*self.sets.values(), self.shown, self.line):
            self.plot.addItem(item)

        self.caption = QLabel()
        self.caption.setWordWrap(True)  # a long fit text never widens the tab past the window
        lay = QVBoxLayout(self)
        lay.addWidget(self.plot, 1)
        lay.addWidget(self.caption)
        redraw_when_shown(self, model)
        self.refresh()

    def refresh(self) -> None:
        m = self.model
        x, y = m.xy()
        ok = (x > 0) & (y > 0)
        groups = m.groups()
        for key, item in self.sets.items():  # log-mode items take linear data and log it themselves
            item.setData(*groups.get(key, ([], [])))
        hl = [(p.signal_dn, p.variance_dn2) for p in m.points
              if p.stage == m.highlighted and p.signal_dn > 0 and p.variance_dn2 > 0]
        self.shown.setData([h[0] for h in hl], [h[1] for h in hl])
        fit = m.fit_line()
        if fit is None:
            self.line.setData([], [])
        else:
            self.line.setData(*fit)
        view = "full frame" if m.fitted else f"view '{m.view}'"
        if not m.points and any(m.by_view.values()):
            parts = [f"No photon-transfer points for the {view}: the engine computed them for "
                     + ", ".join(sorted(k for k, v in m.by_view.items() if v)) + "."]
        else:
            parts = [f"{int(ok.sum())} point(s) of the {view}, as computed by the engine"]
        if m.dark_dn is not None and m.fitted:
            parts.append(f"dark level {m.dark_dn:.2f} DN")
        if math.isfinite(m.gain_e_per_dn) and m.fit_text:
            parts.append(m.fit_text + (f" ({m.fit_note})" if m.fit_note else "")
                         + ("" if m.fitted else "; the engine fits the full frame, drawn here as the dashed line"))
        excluded = [f"{name}: {reason}" for name, (st, reason) in m.status.items() if st == "excluded" and reason]
        if excluded and m.fitted:
            parts.append(f"{len(excluded)} excluded")
            self.caption.setToolTip("\n".join(excluded))
        self.caption.setText(" · ".join(parts))
