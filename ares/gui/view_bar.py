"""The bar above the result tabs: which pixels (view) and which finished stage every
tab shows. One choice serves all tabs, so the panels, maps, profiles, distributions and
the noise components always describe the same pixels of the same stage."""

from __future__ import annotations

from PySide6.QtWidgets import QComboBox, QHBoxLayout, QLabel, QWidget

from ares.gui.models.session import SessionModel

LATEST = "Latest stage (follows the scan)"


class ViewBar(QWidget):
    def __init__(self, session: SessionModel, parent=None) -> None:
        super().__init__(parent)
        self.session = session
        self.view = QComboBox()
        self.view.setMinimumContentsLength(22)
        self.view.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.view.setToolTip("Full frame, a region of the RoA table, a Bayer phase or an ADC channel: "
                             "what every result tab shows.")
        self.stage = QComboBox()
        self.stage.setMinimumContentsLength(22)
        self.stage.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.stage.setToolTip("Any finished stage of the run, or the latest one as the scan goes.")
        lay = QHBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(QLabel("<b>View:</b>"))
        lay.addWidget(self.view, 1)
        lay.addSpacing(12)
        lay.addWidget(QLabel("<b>Stage:</b>"))
        lay.addWidget(self.stage, 1)
        self.view.currentIndexChanged.connect(lambda _: session.select_view(self.view.currentData()))
        self.stage.currentIndexChanged.connect(lambda _: session.show_stage(self.stage.currentData()))
        session.views.subscribe(lambda _: self._fill_views())
        session.regions.subscribe(lambda _: self._fill_views())
        session.stages.subscribe(lambda _: self._fill_stages())
        self._fill_views()
        self._fill_stages()

    @staticmethod
    def _refill(combo: QComboBox, items: list[tuple[object, str]], current) -> None:
        if [(combo.itemData(i), combo.itemText(i)) for i in range(combo.count())] != items:
            combo.blockSignals(True)
            combo.clear()
            for data, text in items:
                combo.addItem(text, data)
            combo.blockSignals(False)
        combo.blockSignals(True)
        combo.setCurrentIndex(max(combo.findData(current), 0))
        combo.blockSignals(False)

    def _fill_views(self) -> None:
        v = self.session.views
        self._refill(self.view, v.choices(), v.selected)

    def _fill_stages(self) -> None:
        st = self.session.stages
        items = [(None, LATEST)] + [(k, f"{k}: {r.name}" + (" (dark)" if r.dark and r.name != "dark" else ""))
                                    for k, r in st.results.items()]
        self._refill(self.stage, items, st.shown)

    def choose_view(self, key: str) -> None:
        self.view.setCurrentIndex(self.view.findData(key))

    def choose_stage(self, stage: int | None) -> None:
        self.stage.setCurrentIndex(self.stage.findData(stage))
