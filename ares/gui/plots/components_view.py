"""Noise Components tab: the engine's 13-component decomposition of the latest stage."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QHeaderView, QLabel, QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget

from ares.gui.layout import redraw_when_shown
from ares.gui.models.components import ComponentsModel


class ComponentsView(QWidget):
    HEADERS = ("Component", "Meaning", "Estimate ± SE", "Unit")

    def __init__(self, model: ComponentsModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.caption = QLabel()
        self.caption.setWordWrap(True)
        self.tables = {}
        self.titles = {}
        lay = QVBoxLayout(self)
        lay.addWidget(self.caption)
        for which, title in (("components", "Stage stack"), ("dark_components", "Matched dark stack")):
            t = QTableWidget(0, len(self.HEADERS))
            t.setHorizontalHeaderLabels(self.HEADERS)
            head = t.horizontalHeader()
            head.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
            # the estimate takes what is left: a long "n/a (reason)" is elided there, whole in
            # its tooltip, and never pushes the Unit column off the window
            head.setSectionResizeMode(self.HEADERS.index("Estimate ± SE"), QHeaderView.ResizeMode.Stretch)
            t.setTextElideMode(Qt.TextElideMode.ElideRight)
            t.setWordWrap(False)
            t.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
            self.titles[which] = QLabel(f"<b>{title}</b>")
            lay.addWidget(self.titles[which])
            lay.addWidget(t, 1)
            self.tables[which] = t
        redraw_when_shown(self, model)
        self.refresh()

    def refresh(self) -> None:
        m = self.model
        if not m.caption:
            self.caption.setText("No decomposition yet: the engine reports the noise components "
                                 "of each stage of a scan file as it finishes.")
        elif m.view not in m.views:
            self.caption.setText(f"{m.caption}: the engine has no decomposition of this view "
                                 f"(views: {', '.join(m.views)}).")
        else:
            n = m.masked_pixels()
            self.caption.setText(f"{m.caption}, engine view '{m.view}'"
                                 + (f"; defects excluded ({n} defect pixels masked out of the decomposition, "
                                    f"as the report and the terminal)" if n else "; all pixels (no defect mask)"))
        for which, table in self.tables.items():
            rows = m.rows(which)
            visible = which == "components" or bool(rows)  # the dark table only when reported apart
            table.setVisible(visible)
            self.titles[which].setVisible(visible)
            table.setRowCount(len(rows))
            for r, row in enumerate(rows):
                for c, text in enumerate((row.symbol, row.description, row.text, row.shown_unit)):
                    item = QTableWidgetItem(text)
                    item.setToolTip(text)
                    table.setItem(r, c, item)
