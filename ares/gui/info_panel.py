"""Information tab: system, scan, versions and run directory (a view of InfoModel)."""

from __future__ import annotations

import platform
import sys

from PySide6.QtWidgets import QHeaderView, QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget

from ares.gui.layout import redraw_when_shown
from ares.gui.models.session import HEADLINE, InfoModel


def versions() -> dict[str, str]:
    import numpy
    import pyqtgraph
    import PySide6
    import scipy

    import ares

    return {
        "ARES version": ares.__version__,
        "Python": f"{platform.python_version()} ({sys.platform})",
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "PySide6": PySide6.__version__,
        "pyqtgraph": pyqtgraph.__version__,
    }


class InfoPanel(QWidget):
    def __init__(self, model: InfoModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.table = QTableWidget(0, 2)
        self.table.setHorizontalHeaderLabels(("Item", "Value"))
        self.table.horizontalHeader().setSectionResizeMode(0, QHeaderView.ResizeMode.ResizeToContents)
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        QVBoxLayout(self).addWidget(self.table)
        redraw_when_shown(self, model)
        self.refresh()

    def refresh(self) -> None:
        items = self.model.ordered()  # the headline figures first, as the terminal prints them
        self.table.setRowCount(len(items))
        for r, (k, v) in enumerate(items):
            name, value = QTableWidgetItem(k), QTableWidgetItem(v)
            value.setToolTip(v)
            if k in HEADLINE:
                font = name.font()
                font.setBold(True)
                name.setFont(font)
            self.table.setItem(r, 0, name)
            self.table.setItem(r, 1, value)

    def rows(self) -> list[tuple[str, str]]:
        """What the table shows, top to bottom."""
        return [(self.table.item(r, 0).text(), self.table.item(r, 1).text()) for r in range(self.table.rowCount())]

    def value(self, key: str) -> str | None:
        return self.model.items.get(key)
