"""Regions of Analysis tab: the On/Off, Draw, X, Y, Width, Height table and the
Load/Save RoA File buttons (a view/editor of ``RegionSet``)."""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (QFileDialog, QHBoxLayout, QHeaderView, QPushButton, QTableWidget,
                               QTableWidgetItem, QVBoxLayout, QWidget)

from ares.errors import AresError

from ares.gui.models.regions import Region, RegionSet

COLUMNS = ("On/Off", "Draw", "X", "Y", "Width", "Height")
RoA_FILTER = "RoA files (*.xml *.csv);;All files (*)"


class RegionsTable(QWidget):
    error = Signal(str)  # one sentence for the status bar / message box

    def __init__(self, regions: RegionSet, parent=None) -> None:
        super().__init__(parent)
        self.regions = regions
        self.load_button = QPushButton("Load RoA File")
        self.save_button = QPushButton("Save RoA File")
        self.table = QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels(COLUMNS)
        self.table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.Stretch)
        self.table.verticalHeader().setDefaultSectionSize(22)
        buttons = QHBoxLayout()
        buttons.addWidget(self.load_button)
        buttons.addWidget(self.save_button)
        buttons.addStretch(1)
        lay = QVBoxLayout(self)
        lay.addLayout(buttons)
        lay.addWidget(self.table)
        self._updating = False
        self.table.itemChanged.connect(self._item_changed)
        self.load_button.clicked.connect(self._load_clicked)
        self.save_button.clicked.connect(self._save_clicked)
        regions.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        self._updating = True
        try:
            self.table.setRowCount(len(self.regions))
            for row, r in enumerate(self.regions.regions):
                for col, value in enumerate((r.on, r.draw, r.x, r.y, r.width, r.height)):
                    item = self.table.item(row, col)
                    if item is None:
                        item = QTableWidgetItem()
                        self.table.setItem(row, col, item)
                    if col < 2:
                        item.setFlags(Qt.ItemFlag.ItemIsUserCheckable | Qt.ItemFlag.ItemIsEnabled)
                        item.setCheckState(Qt.CheckState.Checked if value else Qt.CheckState.Unchecked)
                    else:
                        item.setText(str(value))
                        item.setTextAlignment(Qt.AlignmentFlag.AlignCenter)
        finally:
            self._updating = False

    def _item_changed(self, item: QTableWidgetItem) -> None:
        if self._updating:
            return
        row, col = item.row(), item.column()
        name = ("on", "draw", "x", "y", "width", "height")[col]
        if col < 2:
            value = item.checkState() == Qt.CheckState.Checked
        else:
            try:
                value = int(item.text().strip())
                if col >= 4 and value < 0:
                    raise ValueError
            except ValueError:
                self.error.emit(f"Region {row + 1}: {COLUMNS[col]} must be a whole number"
                                + (" not below 0." if col >= 4 else "."))
                self.refresh()
                return
        self.regions.update(row, **{name: value})

    # ---- programmatic API (used by the tests and the main window) ----------------------
    def set_cell(self, row: int, col: int, value) -> None:
        item = self.table.item(row, col)
        if col < 2:
            item.setCheckState(Qt.CheckState.Checked if value else Qt.CheckState.Unchecked)
        else:
            item.setText(str(value))

    def add_region(self, region: Region) -> int:
        return self.regions.add(region)

    def load(self, path: str) -> bool:
        try:
            self.regions.load(path)
        except AresError as exc:
            self.error.emit(str(exc))
            return False
        return True

    def save(self, path: str) -> bool:
        try:
            self.regions.save(path)
        except AresError as exc:
            self.error.emit(str(exc))
            return False
        return True

    def _load_clicked(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Load RoA File", "", RoA_FILTER)
        if path:
            self.load(path)

    def _save_clicked(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Save RoA File", "regions.xml", RoA_FILTER)
        if path:
            self.save(path)
