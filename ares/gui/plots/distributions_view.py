"""Pixel Distributions tab: the latest frame's histogram in each active region."""

from __future__ import annotations

from PySide6.QtWidgets import QGridLayout, QGroupBox, QLabel, QVBoxLayout, QWidget

from ares.gui.models.session import SessionModel
from ares.gui.plots import region_color
from ares.gui.plots.histogram_view import HistogramPlot


class DistributionsView(QWidget):
    def __init__(self, session: SessionModel, parent=None) -> None:
        super().__init__(parent)
        self.session = session
        self.plots: dict[int, HistogramPlot] = {}
        self._unsubscribe: list = []
        self.grid = QGridLayout()
        self.empty = QLabel("No frame yet: the histograms of each active region's pixels appear with the first frame.")
        lay = QVBoxLayout(self)
        lay.addWidget(self.empty)
        lay.addLayout(self.grid, 1)
        session.distributions_changed.subscribe(lambda _: self.rebuild())
        self.rebuild()

    @staticmethod
    def caption(m) -> str:
        st = m.stats
        if not st.n:
            return "no pixels"
        return (f"{st.n} px · Mean {st.mean:.2f} · Sigma {st.sigma:.2f} · "
                f"Lowest {st.lowest:.0f} · Highest {st.highest:.0f}")

    def rebuild(self) -> None:
        for unsubscribe in self._unsubscribe:  # models outlive these widgets
            unsubscribe()
        self._unsubscribe = []
        while self.grid.count():
            w = self.grid.takeAt(0).widget()
            if w is not None:
                w.setParent(None)
                w.deleteLater()
        self.plots = {}
        items = sorted(self.session.distributions.items())
        self.empty.setVisible(not items)
        cols = 2 if len(items) > 1 else 1
        for k, (i, model) in enumerate(items):
            box = QGroupBox(model.title)
            plot = HistogramPlot(model, color=region_color(i), xlabel="pixel value (DN)")
            caption = QLabel()
            caption.setWordWrap(True)
            lay = QVBoxLayout(box)
            lay.addWidget(plot, 1)
            lay.addWidget(caption)
            self._unsubscribe += [plot.unsubscribe, model.subscribe(lambda m, c=caption: c.setText(self.caption(m)))]
            caption.setText(self.caption(model))
            self.grid.addWidget(box, k // cols, k % cols)
            self.plots[i] = plot
