"""Noise Components tab: the engine's 13-component decomposition of the latest stage."""

from __future__ import annotations

from PySide6.QtWidgets import (QComboBox, QHBoxLayout, QHeaderView, QLabel, QTableWidget, QTableWidgetItem,
                               QVBoxLayout, QWidget)

from ..models.components import ComponentsModel


class ComponentsView(QWidget):
    HEADERS = ("Component", "Meaning", "Estimate ± SE", "Unit")

    def __init__(self, model: ComponentsModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        self.view = QComboBox()
        self.view.setMinimumWidth(140)
        self.caption = QLabel()
        top = QHBoxLayout()
        top.addWidget(QLabel("View:"))
        top.addWidget(self.view)
        top.addWidget(self.caption, 1)
        self.tables = {}
        self.titles = {}
        lay = QVBoxLayout(self)
        lay.addLayout(top)
        for which, title in (("components", "Stage stack"), ("dark_components", "Matched dark stack")):
            t = QTableWidget(0, len(self.HEADERS))
            t.setHorizontalHeaderLabels(self.HEADERS)
            t.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
            t.horizontalHeader().setStretchLastSection(True)
            t.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
            self.titles[which] = QLabel(f"<b>{title}</b>")
            lay.addWidget(self.titles[which])
            lay.addWidget(t, 1)
            self.tables[which] = t
        self.view.currentTextChanged.connect(lambda v: v and v != model.view and model.select(v))
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        m = self.model
        names = list(m.views)
        if names != [self.view.itemText(i) for i in range(self.view.count())]:
            self.view.blockSignals(True)
            self.view.clear()
            self.view.addItems(names)
            self.view.blockSignals(False)
        self.view.blockSignals(True)
        self.view.setCurrentText(m.view)
        self.view.blockSignals(False)
        self.caption.setText(m.caption or "No decomposition yet: the engine reports the noise components "
                             "of each stage of a scan file as it finishes.")
        for which, table in self.tables.items():
            rows = m.rows(which)
            visible = which == "components" or bool(rows)  # the dark table only when reported apart
            table.setVisible(visible)
            self.titles[which].setVisible(visible)
            table.setRowCount(len(rows))
            for r, row in enumerate(rows):
                for c, text in enumerate((row.symbol, row.description, row.text, row.unit)):
                    table.setItem(r, c, QTableWidgetItem(text))
