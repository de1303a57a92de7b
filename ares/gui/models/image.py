"""Image models: the live preview and the signal / noise maps (no Qt).

An image model holds the array to show, the display levels, and the rectangles to
outline (regions with Draw ticked, or all active regions).
"""

from __future__ import annotations

import numpy as np

from ares.gui.models.observable import Observable
from ares.gui.models.regions import Region


LEVEL_SAMPLES = 1 << 16
# A new frame keeps the shown levels while its own differ from them by less than this
# fraction of their span at both ends: the colour scale holds still over a stage (frame to
# frame noise no longer redraws the colour bar's axis at every preview) and follows a
# change of light level at once.
STEADY_LEVELS = 0.05


def robust_levels(image: np.ndarray, lo_pct: float = 0.5, hi_pct: float = 99.5) -> tuple[float, float]:
    """Display levels that ignore the few hottest/coldest pixels, from a regular grid of
    at most ~65k pixels (display only: a VGA frame's percentiles cost 16x less)."""
    image = np.asarray(image)
    if image.ndim == 2 and image.size > LEVEL_SAMPLES:
        step = int(np.ceil(np.sqrt(image.size / LEVEL_SAMPLES)))
        image = image[::step, ::step]
    v = np.asarray(image, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (0.0, 1.0)
    lo, hi = (float(x) for x in np.percentile(v, [lo_pct, hi_pct]))
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    return lo, hi


class ImageModel(Observable):
    def __init__(self, title: str = "") -> None:
        super().__init__()
        self.title = title
        self.image: np.ndarray | None = None
        self.levels: tuple[float, float] = (0.0, 1.0)
        self.rectangles: list[tuple[int, Region]] = []
        self.caption = ""

    def set_image(self, image: np.ndarray | None, caption: str = "",
                  levels: tuple[float, float] | None = None) -> None:
        self.image = None if image is None else np.asarray(image)
        self.caption = caption
        if self.image is not None:
            new = levels if levels is not None else robust_levels(self.image)
            lo, hi = self.levels
            if levels is not None or max(abs(new[0] - lo), abs(new[1] - hi)) > STEADY_LEVELS * (hi - lo):
                self.levels = new
        self._changed()

    def set_rectangles(self, rectangles: list[tuple[int, Region]]) -> None:
        rectangles = list(rectangles)
        if rectangles != self.rectangles:  # unchanged: no redraw (keeps a drag in progress alive)
            self.rectangles = rectangles
            self._changed()
