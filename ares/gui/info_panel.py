"""Information tab: system, scan, versions and run directory (a view of InfoModel)."""

from __future__ import annotations

import platform
import sys

from PySide6.QtWidgets import QHeaderView, QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget

from .layout import redraw_when_shown
from .models.session import InfoModel


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
        items = list(self.model.items.items())
        self.table.setRowCount(len(items))
        for r, (k, v) in enumerate(items):
            self.table.setItem(r, 0, QTableWidgetItem(k))
            self.table.setItem(r, 1, QTableWidgetItem(v))

    def value(self, key: str) -> str | None:
        return self.model.items.get(key)
