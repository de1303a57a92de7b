"""Small layout helpers shared by the window's panels."""

from __future__ import annotations

from PySide6.QtCore import QEvent, QObject
from PySide6.QtWidgets import QScrollArea, QWidget


def scrolled(widget: QWidget) -> QScrollArea:
    """A page that scrolls rather than widen the window: the window fits a 1280x800 screen."""
    area = QScrollArea()
    area.setWidget(widget)
    area.setWidgetResizable(True)
    area.setFrameShape(QScrollArea.Shape.NoFrame)
    return area


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
