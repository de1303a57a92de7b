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
    the 2..9 minor ticks unlabelled, so labels never overlap; within less than two decades
    it labels the 1-2-5 ticks (every tick when there are few)."""

    def logTickValues(self, minVal, maxVal, size, stdTicks):  # noqa: N802,N803 -- pyqtgraph's names
        """pyqtgraph's, without the decades again among the minor ticks (drawn twice)."""
        seen: list[float] = []
        out = []
        for spacing, values in super().logTickValues(minVal, maxVal, size, stdTicks):
            values = [v for v in values if all(abs(v - u) > 1e-9 for u in seen)]
            seen.extend(values)
            out.append((spacing, values))
        return out

    def logTickStrings(self, values, scale, spacing):  # noqa: N802 -- pyqtgraph's name
        import math

        lo, hi = sorted(self.range)  # the axis' range in decades
        if math.floor(hi + 1e-9) - math.ceil(lo - 1e-9) + 1 >= 2:  # two decades or more in view
            return [f"{10 ** round(v) * scale:g}" if abs(v - round(v)) < 1e-9 else "" for v in values]
        keep = len(values) <= 5
        out = []
        for v in values:
            text = f"{10 ** v * scale:.3g}"
            lead = text.lstrip("-0.")[:1]
            out.append(text if keep or lead in ("1", "2", "5") else "")
        return out


def nice_ticks(lo: float, hi: float) -> list[tuple[float, str]]:
    """Three to about eight round values within [lo, hi] (steps of 1, 2, 2.5 or 5 times a
    power of ten) and their labels, with just the digits that tell neighbours apart --
    also for a range like 0.27990..0.27998 or 1e-6..1.5e-6, where pyqtgraph's own ticks
    on a colour bar were none or one."""
    import math

    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [(lo, f"{lo:.4g}")] if math.isfinite(lo) else []
    span = hi - lo
    e = math.floor(math.log10(span / 4))
    best = None
    for k in (e + 1, e, e - 1):
        for m in (5, 2.5, 2, 1):
            step = m * 10.0 ** k
            first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
            if last - first + 1 >= 3:
                best = (step, m, first, last)
                break
        if best:
            break
    step, m, first, last = best
    values = [i * step for i in range(first, last + 1)]
    frac = -math.floor(math.log10(step)) + (1 if m == 2.5 else 0)  # digits after the point the step needs
    top = max(abs(lo), abs(hi))
    if top >= 1e5 or top < 1e-3:  # exponent form, with the significant digits the step needs
        sig = max(math.floor(math.log10(top)) + frac, 0)
        labels = ["0" if v == 0 else f"{v:.{sig}e}" for v in values]
    else:
        labels = [f"{v:.{max(frac, 0)}f}" for v in values]
    return list(zip(values, labels))


def set_colorbar_levels(colorbar, levels) -> None:
    """A colour bar's range with readable ticks (``nice_ticks``), its axis as wide as its
    longest label."""
    lo, hi = (float(v) for v in levels)
    colorbar.setLevels((lo, hi))
    ticks = nice_ticks(lo, hi)
    axis = colorbar.axis
    axis.setTicks([ticks])
    from PySide6.QtGui import QFontMetrics

    fm = QFontMetrics(axis.style.get("tickFont") or axis.font())
    axis.setWidth(max(45, max((fm.horizontalAdvance(t) for _, t in ticks), default=0) + 18))
