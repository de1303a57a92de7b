"""pyqtgraph views; each draws one model from ``ares.gui.models`` and holds no data of
its own beyond what it shows."""

import pyqtgraph as pg

pg.setConfigOptions(imageAxisOrder="row-major", antialias=True, background="w", foreground="k")

# One colour per RoA table row (cycled), used for outlines, histograms and profiles.
REGION_COLORS = [
    (220, 40, 40), (30, 120, 220), (20, 160, 60), (230, 140, 0), (150, 60, 200),
    (0, 170, 170), (200, 60, 140), (120, 120, 0),
]


def region_color(index: int) -> tuple[int, int, int]:
    return (60, 60, 60) if index < 0 else REGION_COLORS[index % len(REGION_COLORS)]


def plain_axes(plot) -> None:
    """No automatic SI prefixes: a 3.4 "kDN" axis reads worse than 3400 DN."""
    item = plot.getPlotItem() if hasattr(plot, "getPlotItem") else plot
    for name in ("bottom", "left"):
        item.getAxis(name).enableAutoSIPrefix(False)


class DecadeAxis(pg.AxisItem):
    """A log-mode axis that labels the decades (1, 10, 100 ... as plain numbers) and leaves
    the 2..9 minor ticks unlabelled, so labels never overlap; within one decade every tick
    is labelled."""

    def logTickStrings(self, values, scale, spacing):  # noqa: N802 -- pyqtgraph's name
        decades = [abs(v - round(v)) < 1e-9 for v in values]
        if sum(decades) < 2:
            return [f"{10 ** v * scale:.3g}" for v in values]
        return [f"{10 ** round(v) * scale:g}" if d else "" for v, d in zip(values, decades)]
