"""A minimal change-notification base for plot models (no Qt).

Views subscribe a callable; models call ``_changed()`` after each update. This keeps
models testable without a GUI (the bluesky-widgets split: model here, Qt view in
``ares.gui.plots``).
"""

from __future__ import annotations

import contextlib
from typing import Callable


class Observable:
    def __init__(self) -> None:
        self._listeners: list[Callable[[object], None]] = []
        self._held, self._missed = 0, False

    def subscribe(self, fn: Callable[[object], None]) -> Callable[[], None]:
        """Call ``fn(model)`` after every change; returns an unsubscribe function."""
        self._listeners.append(fn)

        def unsubscribe() -> None:
            if fn in self._listeners:
                self._listeners.remove(fn)

        return unsubscribe

    @contextlib.contextmanager
    def batch(self):
        """Changes inside the block notify once, at its end (a stage's result moves the PTC
        three times: one redraw, not three)."""
        self._held += 1
        try:
            yield self
        finally:
            self._held -= 1
            if not self._held and self._missed:
                self._changed()

    def _changed(self) -> None:
        if self._held:
            self._missed = True
            return
        self._missed = False
        for fn in list(self._listeners):
            fn(self)
