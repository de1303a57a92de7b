"""MEAN SIGNAL / NOISE / COLUMNS / ROWS panels: histogram, range mode, statistics."""

from __future__ import annotations

import math

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QComboBox, QDoubleSpinBox, QGridLayout, QGroupBox, QLabel,
                               QPushButton, QVBoxLayout, QWidget)

from ares.gui.models.session import PANELS, RESULTS_S, SessionModel
from ares.gui.models.stats import RANGE_MODES, StatsPanelModel
from ares.gui.plots.histogram_view import HistogramPlot

STAT_FIELDS = (("Mean", "mean"), ("Sigma", "sigma"), ("Fitted Mean", "fitted_mean"),
               ("Fitted Sigma", "fitted_sigma"), ("Lowest", "lowest"), ("Highest", "highest"))


def fmt(x: float) -> str:
    return "n/a" if not math.isfinite(x) else f"{x:.2f}"


class StatsPanel(QGroupBox):
    """One ARES statistics panel, a view of a ``StatsPanelModel``."""

    def __init__(self, model: StatsPanelModel, xlabel: str = "DN", parent=None) -> None:
        super().__init__(model.title, parent)
        self.model = model
        self.setStyleSheet("QGroupBox { font-weight: bold; }")
        self.histogram = HistogramPlot(model, xlabel=xlabel)
        self.histogram.setMinimumHeight(120)
        self.mode = QComboBox()
        self.mode.addItems(RANGE_MODES)
        self.mode.setMinimumContentsLength(11)  # the panels' 2 x 2 grid fits a 1280-pixel screen
        self.mode.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.frm = self._spin()
        self.to = self._spin()
        self.restore_button = QPushButton("Restore")
        self.labels = {attr: QLabel("n/a") for _, attr in STAT_FIELDS}

        # Range Mode [combo] [Restore] / From [..] To [..] / Mean Sigma / Fitted Mean Fitted
        # Sigma / Lowest Highest: two label-value pairs per row keeps the panel narrow
        # enough for a 2 x 2 grid beside the control column on a 1400-pixel screen.
        right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
        stats = QGridLayout()
        stats.setHorizontalSpacing(4)
        stats.setVerticalSpacing(2)
        stats.addWidget(QLabel("Range Mode:"), 0, 0, right)
        stats.addWidget(self.mode, 0, 1, 1, 2)  # its text whole: it spans the To: label's column
        stats.addWidget(self.restore_button, 0, 3)
        stats.addWidget(QLabel("From:"), 1, 0, right)
        stats.addWidget(self.frm, 1, 1)
        stats.addWidget(QLabel("To:"), 1, 2, right)
        stats.addWidget(self.to, 1, 3)
        for k, (name, attr) in enumerate(STAT_FIELDS):
            row, col = 2 + k // 2, 2 * (k % 2)
            self.labels[attr].setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
            stats.addWidget(QLabel(name + ":"), row, col, right)
            stats.addWidget(self.labels[attr], row, col + 1)
        stats.setColumnStretch(1, 1)
        stats.setColumnStretch(3, 1)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(4, 4, 4, 4)
        lay.addWidget(self.histogram, 1)
        lay.addLayout(stats)
        for w in self.findChildren(QLabel):
            w.setStyleSheet("font-weight: normal;")

        self.mode.currentTextChanged.connect(self._mode_chosen)
        self.frm.editingFinished.connect(self._range_typed)
        self.to.editingFinished.connect(self._range_typed)
        self.restore_button.clicked.connect(model.restore)
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    @staticmethod
    def _spin() -> QDoubleSpinBox:
        s = QDoubleSpinBox()
        s.setRange(-1e9, 1e9)
        s.setDecimals(2)
        s.setKeyboardTracking(False)
        s.setMinimumWidth(60)
        return s

    def _mode_chosen(self, mode: str) -> None:
        if mode != self.model.range_mode:
            if mode == "Manual":
                self.model.set_range(*self.model.range)
            else:
                self.model.set_range_mode(mode)

    def _range_typed(self) -> None:
        frm, to = self.frm.value(), self.to.value()
        if (round(frm, 2), round(to, 2)) != tuple(round(v, 2) for v in self.model.range):
            self.model.set_range(frm, to)

    def refresh(self) -> None:
        m = self.model
        for w, v in ((self.frm, m.range[0]), (self.to, m.range[1])):
            w.blockSignals(True)
            w.setValue(v)
            w.blockSignals(False)
        self.mode.blockSignals(True)
        self.mode.setCurrentText(m.range_mode)
        self.mode.blockSignals(False)
        for _, attr in STAT_FIELDS:
            self.labels[attr].setText(fmt(getattr(m.stats, attr)))


class ResultsTab(QWidget):
    """The Results tab: the four panels of the stage and view chosen in the view bar."""

    def __init__(self, session: SessionModel, parent=None) -> None:
        super().__init__(parent)
        self.session = session
        self.caption = QLabel()
        grid = QGridLayout()
        # (the axis label fits the panel at 1280 x 800: the note on the report's signal is the tooltip)
        xlabels = {"MEAN SIGNAL": "mean output (DN, offset included)", "NOISE": "temporal sigma (DN)",
                   "COLUMNS": "column mean (DN)", "ROWS": "row mean (DN)"}
        self.panels = {name: StatsPanel(session.panels[name], xlabels[name]) for name in PANELS}
        self.panels["MEAN SIGNAL"].setTitle("MEAN SIGNAL (raw output, offset included)")
        self.panels["MEAN SIGNAL"].setToolTip("The raw output, offset included: the report's and the terminal's "
                                              "signal is the mean above dark.")
        for k, name in enumerate(PANELS):
            grid.addWidget(self.panels[name], k // 2, k % 2)
        lay = QVBoxLayout(self)
        lay.addWidget(self.caption)
        lay.addLayout(grid, 1)
        session.panels["MEAN SIGNAL"].subscribe(lambda _: self._caption())
        self._caption()

    def _caption(self) -> None:
        ev = self.session.panels_stage
        if ev is None:
            self.caption.setText("No stage result yet.")
        elif ev.mean is None:
            self.caption.setText(f"Stage {ev.stage} ({ev.name}): its arrays were dropped to bound memory.")
        else:
            live = (f" (while the scan runs, its newest stage is drawn at most every {RESULTS_S:g} s)"
                    if self.session.throttle and self.session.stages.following_latest else "")
            self.caption.setText(f"Stage {ev.stage} ({ev.name}), {ev.frames} frames, "
                                 f"{self.session.region_label(ev.mean.shape)}{live}")
