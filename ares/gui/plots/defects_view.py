"""Defect Counts table, and the tunable thresholds: edit a value and press
"Re-classify last run" to classify the last run again from its directory."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (QCheckBox, QHeaderView, QLabel, QPushButton, QTableWidget, QTableWidgetItem, QVBoxLayout,
                               QWidget)

from ares.gui.layout import redraw_when_shown
from ares.gui.models.defects import DEFECT_COLORS, DefectCountsModel, reclassify, threshold_defaults


class DefectCountsView(QWidget):
    HEADERS = ("Defect class", "Count", "ppm", "Criterion")

    def __init__(self, model: DefectCountsModel, parent=None, run_dir=lambda: "", on_error=print) -> None:
        super().__init__(parent)
        self.model = model
        self.run_dir, self.on_error = run_dir, on_error
        self.caption = QLabel()
        self.caption.setWordWrap(True)  # a long list of stages must not widen the tab past 1280 x 800
        self.table = QTableWidget(0, len(self.HEADERS))
        self.table.setHorizontalHeaderLabels(self.HEADERS)
        head = self.table.horizontalHeader()
        head.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        # the criterion takes the room left (wrapped, its full text in the tooltip), never more
        head.setSectionResizeMode(len(self.HEADERS) - 1, QHeaderView.ResizeMode.Stretch)
        self.table.setWordWrap(True)
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.overlay = QCheckBox("Show the defect map on the images (colours as in the first column)")
        self.overlay.toggled.connect(model.set_overlay)
        lay = QVBoxLayout(self)
        lay.addWidget(self.caption)
        lay.addWidget(self.table, 3)
        lay.addWidget(self.overlay)
        self.defaults = dict(threshold_defaults())
        self._shown = dict(self.defaults)
        self.thresholds = QTableWidget(len(self.defaults), 2)
        self.thresholds.setHorizontalHeaderLabels(("Threshold / limit", "Value (empty = default / none)"))
        self.thresholds.horizontalHeader().setStretchLastSection(True)
        for r, (name, value) in enumerate(self.defaults.items()):
            item = QTableWidgetItem(name)
            item.setFlags(item.flags() & ~Qt.ItemFlag.ItemIsEditable)
            self.thresholds.setItem(r, 0, item)
            self.thresholds.setItem(r, 1, QTableWidgetItem(value))
        self.reclassify_button = QPushButton("Re-classify last run")
        self.reclassify_button.clicked.connect(self.reclassify)
        lay.addWidget(QLabel("Thresholds (edited values replace the scan's <defects>):"))
        lay.addWidget(self.thresholds, 2)
        lay.addWidget(self.reclassify_button)
        redraw_when_shown(self, model)
        self.refresh()

    def refresh(self) -> None:
        rows = self.model.rows
        self.caption.setText(self.model.caption or "No defect counts yet: the engine reports them when a stage or scan that classifies defects finishes.")
        self.table.setRowCount(len(rows))
        for r, row in enumerate(rows):
            for c, text in enumerate((row.name, row.count_text, row.ppm_text, row.criterion)):
                item = QTableWidgetItem(text)
                if c == 0 and row.name in DEFECT_COLORS:  # the overlay's colour for this class
                    item.setForeground(QColor(*DEFECT_COLORS[row.name]))
                if c == 3:
                    item.setToolTip(text)
                self.table.setItem(r, c, item)
        self.overlay.setEnabled(bool(self.model.map))
        shown = {**self.defaults, **self.model.thresholds}  # the run's values, not the defaults it did not use
        if shown != self._shown:
            self._shown = shown
            for r, name in enumerate(self.defaults):
                self.thresholds.item(r, 1).setText(shown[name])

    def set_threshold(self, name: str, value: str) -> None:
        row = list(self.defaults).index(name)
        self.thresholds.item(row, 1).setText(value)

    def overrides(self) -> dict[str, str]:
        """The values edited away from the run's (its scan's, else the defaults)."""
        out = {}
        for r, name in enumerate(self.defaults):
            text = self.thresholds.item(r, 1).text().strip()
            if text and text != self._shown[name]:
                out[name] = text
        return out

    def reclassify(self) -> None:
        try:
            counts, pixels, caption, res = reclassify(self.run_dir(), self.overrides())
        except Exception as exc:  # noqa: BLE001 -- one sentence, never a traceback
            from ares.gui.worker import one_sentence

            self.on_error(one_sentence(exc))
            return
        self.model.set_counts(counts, pixels, res.get("criteria"), caption=caption)
        self.model.set_map({k: res[k] for k in ("shape", "locations", "bad_column_x", "bad_row_y") if k in res})
