"""Small layout helpers shared by the window's panels."""

from __future__ import annotations

from PySide6.QtCore import QEvent, QObject, Qt
from PySide6.QtWidgets import QLabel, QScrollArea, QSizePolicy, QWidget


def scrolled(widget: QWidget) -> QScrollArea:
    """A page that scrolls rather than widen the window: the window fits a 1280x800 screen."""
    area = QScrollArea()
    area.setWidget(widget)
    area.setWidgetResizable(True)
    area.setFrameShape(QScrollArea.Shape.NoFrame)
    return area


class ElidedLabel(QLabel):
    """A one-line label that never widens its panel: the text is elided ("…") to the width
    it is given and the full text is its tooltip. ``shown_text()`` is what is drawn."""

    def __init__(self, text: str = "", parent=None) -> None:
        super().__init__(parent)
        self._full = ""
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Preferred)
        self.setMinimumWidth(40)
        self.setText(text)

    def setText(self, text: str) -> None:  # noqa: N802 -- Qt's name
        self._full = str(text)
        self.setToolTip(self._full)
        self._elide()

    def text(self) -> str:
        return self._full

    def shown_text(self) -> str:
        return super().text()

    def full_width(self) -> int:
        """Pixels the whole text needs."""
        return self.fontMetrics().horizontalAdvance(self._full) + 2 * self.margin() + 4

    def sizeHint(self):  # noqa: N802 -- Qt's name
        hint = super().sizeHint()
        hint.setWidth(self.full_width())
        return hint

    def resizeEvent(self, event) -> None:  # noqa: N802 -- Qt's name
        super().resizeEvent(event)
        self._elide()

    def _elide(self) -> None:
        shown = self.fontMetrics().elidedText(self._full, Qt.TextElideMode.ElideRight, max(self.width() - 4, 0))
        if shown != super().text():
            super().setText(shown)


class _WhenShown(QObject):
    def __init__(self, widget: QWidget, refresh) -> None:
        super().__init__(widget)
        self.widget, self.refresh, self.stale = widget, refresh, False
        widget.installEventFilter(self)

    def changed(self, _=None) -> None:
        if self.widget.isVisible() or not self.widget.window().isVisible():
            self.stale = False
            self.refresh()
        else:
            self.stale = True  # a tab not in front: drawn when it is shown

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 -- Qt's name
        if event.type() == QEvent.Type.Show and self.stale:
            self.stale = False
            self.refresh()
        return False


def redraw_when_shown(widget: QWidget, model) -> None:
    """Redraw ``widget`` (its ``refresh()``) when ``model`` changes, if it is on screen; a
    widget in a tab not in front (of a window that is shown) is redrawn once, when it is
    next shown. A scan changes the PTC, sweep, decomposition and information models at
    every stage: drawing them unseen took the window's thread -- and the interpreter the
    scan's threads share -- for nothing."""
    model.subscribe(_WhenShown(widget, widget.refresh).changed)
