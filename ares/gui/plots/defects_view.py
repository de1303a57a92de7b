"""Defect Counts table, and the tunable thresholds: edit a value and press
"Re-classify last run" to classify the last run again from its directory."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QHeaderView, QLabel, QPushButton, QTableWidget, QTableWidgetItem, QVBoxLayout,
                               QWidget)

from ..models.defects import DefectCountsModel, reclassify, threshold_defaults


class DefectCountsView(QWidget):
    HEADERS = ("Defect class", "Count", "ppm", "Criterion")

    def __init__(self, model: DefectCountsModel, parent=None, run_dir=lambda: "", on_error=print) -> None:
        super().__init__(parent)
        self.model = model
        self.run_dir, self.on_error = run_dir, on_error
        self.caption = QLabel()
        self.table = QTableWidget(0, len(self.HEADERS))
        self.table.setHorizontalHeaderLabels(self.HEADERS)
        self.table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        lay = QVBoxLayout(self)
        lay.addWidget(self.caption)
        lay.addWidget(self.table, 3)
        self.defaults = dict(threshold_defaults())
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
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        rows = self.model.rows
        self.caption.setText(self.model.caption or "No defect counts yet: the engine reports them when a stage or scan that classifies defects finishes.")
        self.table.setRowCount(len(rows))
        for r, row in enumerate(rows):
            for c, text in enumerate((row.name, str(row.count), f"{row.ppm:.1f}", row.criterion)):
                self.table.setItem(r, c, QTableWidgetItem(text))

    def set_threshold(self, name: str, value: str) -> None:
        row = list(self.defaults).index(name)
        self.thresholds.item(row, 1).setText(value)

    def overrides(self) -> dict[str, str]:
        """The values edited away from their defaults."""
        out = {}
        for r, name in enumerate(self.defaults):
            text = self.thresholds.item(r, 1).text().strip()
            if text and text != self.defaults[name]:
                out[name] = text
        return out

    def reclassify(self) -> None:
        try:
            counts, pixels, caption = reclassify(self.run_dir(), self.overrides())
        except Exception as exc:  # noqa: BLE001 -- one sentence, never a traceback
            from ..worker import one_sentence

            self.on_error(one_sentence(exc))
            return
        self.model.set_counts(counts, pixels, caption=caption)
