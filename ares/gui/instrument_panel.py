"""Instrumentation tab: the system XML, its instruments, and live control of the bench
between scans -- register fields by name (the register map's limits), the light level,
the chamber set point, and a test frame into the live image."""

from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (QDoubleSpinBox, QFileDialog, QGridLayout, QHeaderView, QLabel,
                               QLineEdit, QPushButton, QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget)

from ares.errors import AresError

from ares.gui.models.instruments import InstrumentSession

FIELD_HEADERS = ("Field", "Value", "Unit", "Limits", "Access")
VALUE_COL = 1


class InstrumentationTab(QWidget):
    error = Signal(str)
    frame = Signal(object)  # a grabbed test frame (2-D array)
    system_chosen = Signal(str)

    def __init__(self, model: InstrumentSession | None = None, parent=None) -> None:
        super().__init__(parent)
        self.model = model or InstrumentSession()
        self.path = QLineEdit()
        self.path.setPlaceholderText("the scan's own <system href>")
        self.path.setToolTip("System XML the next scan runs on (as ares run --system), and the bench "
                             "this tab connects to. Empty: the scan's own system.")
        browse = QPushButton("Browse…")
        self.connect_button = QPushButton("Connect")
        self.connect_button.setCheckable(True)
        top = QGridLayout()  # two rows: the window's left column is narrow at 1280 px
        top.addWidget(QLabel("System:"), 0, 0)
        top.addWidget(self.path, 0, 1, 1, 2)
        top.addWidget(browse, 1, 1)
        top.addWidget(self.connect_button, 1, 2)
        top.setColumnStretch(1, 1)
        top.setColumnStretch(2, 1)
        self.instruments = QTableWidget(0, 2)
        self.instruments.setHorizontalHeaderLabels(("Instrument", "Description"))
        self.instruments.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.instruments.horizontalHeader().setStretchLastSection(True)
        self.instruments.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.instruments.setMaximumHeight(130)
        self.fields = QTableWidget(0, len(FIELD_HEADERS))
        self.fields.setHorizontalHeaderLabels(FIELD_HEADERS)
        self.fields.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.fields.horizontalHeader().setStretchLastSection(True)
        self.light = self._spin(0, 1e12, 3)
        self.chamber = self._spin(-100, 300, 2)
        self.light_button, self.chamber_button = QPushButton("Set"), QPushButton("Set")
        self.read_button, self.grab_button = QPushButton("Read All"), QPushButton("Grab Test Frame")
        self.status = QLabel(self.model.message)
        self.status.setWordWrap(True)
        live = QGridLayout()
        live.addWidget(QLabel("Light level:"), 0, 0)
        live.addWidget(self.light, 0, 1)
        live.addWidget(self.light_button, 0, 2)
        live.addWidget(QLabel("Chamber set point (°C):"), 1, 0)
        live.addWidget(self.chamber, 1, 1)
        live.addWidget(self.chamber_button, 1, 2)
        live.addWidget(self.read_button, 2, 0)
        live.addWidget(self.grab_button, 2, 1, 1, 2)
        live.setColumnStretch(1, 1)
        lay = QVBoxLayout(self)
        lay.addLayout(top)
        lay.addWidget(self.instruments)
        hint = QLabel("Register fields: double-click a value to write it (limits from the register map).")
        hint.setWordWrap(True)
        lay.addWidget(hint)
        lay.addWidget(self.fields, 1)
        lay.addLayout(live)
        lay.addWidget(self.status)

        browse.clicked.connect(self._browse)
        self.path.editingFinished.connect(lambda: self.choose(self.path.text().strip()))
        self.connect_button.toggled.connect(self._connect_toggled)
        self.fields.itemChanged.connect(self._field_edited)
        self.light_button.clicked.connect(lambda: self._try(self.model.set_light, self.light.value()))
        self.chamber_button.clicked.connect(lambda: self._try(self.model.set_chamber, self.chamber.value()))
        self.read_button.clicked.connect(lambda: self._try(self.model.read_all))
        self.grab_button.clicked.connect(self._grab)
        self.model.subscribe(lambda _: self.refresh())
        self.refresh()

    @staticmethod
    def _spin(lo: float, hi: float, decimals: int) -> QDoubleSpinBox:
        s = QDoubleSpinBox()
        s.setRange(lo, hi)
        s.setDecimals(decimals)
        s.setKeyboardTracking(False)
        return s

    # ---- actions ----------------------------------------------------------------------
    def _try(self, fn, *args):
        try:
            return fn(*args)
        except AresError as exc:
            self.error.emit(str(exc))
        except OSError as exc:  # a device node or port that went away
            self.error.emit(f"{self.model.path}: {exc.strerror or exc}.")
        self.refresh()
        return None

    def _browse(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "System XML", "protocols", "System files (*.xml);;All files (*)")
        if path:
            self.path.setText(path)
            self.choose(path)

    def choose(self, path: str) -> None:
        """Use this system for the next scan and for the bench here ('' = the scan's own)."""
        if path == (self.model.path or ""):
            return
        if not path:
            self.model.close()
            self.model.path = self.model.system = None
            self.model.message = "The scan's own system."
            self.refresh()
            self.system_chosen.emit("")
            return
        if self._try(self.model.choose, path) is None and self.model.path == path:
            self.system_chosen.emit(path)

    def _connect_toggled(self, on: bool) -> None:
        if on and not self.model.connected:
            self._try(self.model.open)
            bench = self.model.bench
            if bench is not None:  # the set points start where the devices are
                if bench.light is not None:
                    self.light.setValue(bench.light.get_level())
                if bench.chamber is not None:
                    self.chamber.setValue(bench.chamber.get_temperature())
        elif not on and self.model.connected:
            self._try(self.model.close)
        self.refresh()

    def disconnect_bench(self) -> None:
        """Before a scan: the scan opens the devices itself."""
        if self.model.connected:
            self._try(self.model.close)

    def write_field(self, name: str, value) -> None:
        self._try(self.model.write, name, value)

    def _field_edited(self, item: QTableWidgetItem) -> None:
        if item.column() == VALUE_COL:
            name = self.fields.item(item.row(), 0).text()
            self.write_field(name, item.text())
            self.refresh()  # the value read back (or the old one after an error)

    def _grab(self) -> None:
        image = self._try(self.model.grab)
        if image is not None:
            self.frame.emit(image)

    # ---- drawing ----------------------------------------------------------------------
    def show_instruments(self, instruments: dict) -> None:
        self.instruments.setRowCount(len(instruments))
        for r, (k, v) in enumerate(instruments.items()):
            self.instruments.setItem(r, 0, QTableWidgetItem(str(k)))
            self.instruments.setItem(r, 1, QTableWidgetItem(str(v)))

    def refresh(self) -> None:
        m = self.model
        from PySide6.QtCore import Qt

        rows = m.fields()
        self.fields.blockSignals(True)
        self.fields.setRowCount(len(rows))
        for r, row in enumerate(rows):
            value = "" if row.value is None else f"{row.value:.6g}"
            for c, text in enumerate((row.name, value, row.unit, row.limits, row.access)):
                item = QTableWidgetItem(text)
                editable = c == VALUE_COL and m.connected and row.access != "ro"
                flags = item.flags() & ~Qt.ItemFlag.ItemIsEditable
                item.setFlags(flags | Qt.ItemFlag.ItemIsEditable if editable else flags)
                if c == 0:
                    item.setToolTip(row.description)
                self.fields.setItem(r, c, item)
        self.fields.blockSignals(False)
        for w in (self.light_button, self.chamber_button, self.read_button, self.grab_button):
            w.setEnabled(m.connected)
        self.connect_button.blockSignals(True)
        self.connect_button.setChecked(m.connected)
        self.connect_button.setText("Disconnect" if m.connected else "Connect")
        self.connect_button.setEnabled(m.system is not None)
        self.connect_button.blockSignals(False)
        readings = m.readings() if m.connected else {}
        self.status.setText(m.message + ("  " + ", ".join(f"{k}: {v}" for k, v in readings.items())
                                         if readings else ""))
