"""A minimal change-notification base for plot models (no Qt).

Views subscribe a callable; models call ``_changed()`` after each update. This keeps
models testable without a GUI (the bluesky-widgets split: model here, Qt view in
``ares.gui.plots``).
"""

from __future__ import annotations

from typing import Callable


class Observable:
    def __init__(self) -> None:
        self._listeners: list[Callable[[object], None]] = []

    def subscribe(self, fn: Callable[[object], None]) -> Callable[[], None]:
        """Call ``fn(model)`` after every change; returns an unsubscribe function."""
        self._listeners.append(fn)

        def unsubscribe() -> None:
            if fn in self._listeners:
                self._listeners.remove(fn)

        return unsubscribe

    def _changed(self) -> None:
        for fn in list(self._listeners):
            fn(self)
