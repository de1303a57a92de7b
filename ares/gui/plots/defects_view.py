"""Defect Counts table."""

from __future__ import annotations

from PySide6.QtWidgets import QHeaderView, QLabel, QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget

from ..models.defects import DefectCountsModel


class DefectCountsView(QWidget):
    HEADERS = ("Defect class", "Count", "ppm", "Criterion")

    def __init__(self, model: DefectCountsModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.caption = QLabel()
        self.table = QTableWidget(0, len(self.HEADERS))
        self.table.setHorizontalHeaderLabels(self.HEADERS)
        self.table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        lay = QVBoxLayout(self)
        lay.addWidget(self.caption)
        lay.addWidget(self.table)
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        rows = self.model.rows
        self.caption.setText(self.model.caption or "No defect counts yet: the engine reports them when a stage or scan that classifies defects finishes.")
        self.table.setRowCount(len(rows))
        for r, row in enumerate(rows):
            for c, text in enumerate((row.name, str(row.count), f"{row.ppm:.1f}", row.criterion)):
                self.table.setItem(r, c, QTableWidgetItem(text))
