"""Statistics panel model: MEAN SIGNAL / NOISE / COLUMNS / ROWS (no Qt).

Given the values a panel shows (per-pixel means, per-pixel temporal sigmas, column or
row means of a region), it keeps the display range (From/To, set by a range mode or by
hand) and the histogram drawn over it. The numbers ARES prints under it -- Mean, Sigma,
Fitted Mean, Fitted Sigma, Lowest, Highest -- come from the analysis engine
(``ares.analysis.noise.panels.summarize``: the fit is its robust Gaussian fit to the
histogram core) applied to the values inside From..To.

Range modes:
- "Peak to Peak": From/To = Lowest/Highest widened by 15 % of the peak-to-peak span on
  each side (the margins in the ARES screenshots: 32.20..37.80 -> 31.36..38.64).
- "Mean ± 3 Sigma", "Mean ± 5 Sigma": centred on the mean of all values.
- "Percentile 0.1–99.9": the engine's percentile range (drops the extreme 0.1 % tails).
- "Manual": From/To as typed; ``restore()`` returns to Peak to Peak.

The statistics use the values inside [From, To] (all of them in Peak to Peak and the
sigma modes), so a manual range can exclude outliers. Sigma uses ddof=1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.gui.models.observable import Observable

PEAK_TO_PEAK = "Peak to Peak"
MEAN_3_SIGMA = "Mean ± 3 Sigma"
MEAN_5_SIGMA = "Mean ± 5 Sigma"
PERCENTILE = "Percentile 0.1–99.9"
MANUAL = "Manual"
RANGE_MODES = (PEAK_TO_PEAK, MEAN_3_SIGMA, MEAN_5_SIGMA, PERCENTILE, MANUAL)
PEAK_MARGIN = 0.15
DEFAULT_BINS = 64


@dataclass(frozen=True)
class PanelStats:
    n: int = 0
    mean: float = math.nan
    sigma: float = math.nan
    fitted_mean: float = math.nan
    fitted_sigma: float = math.nan
    lowest: float = math.nan
    highest: float = math.nan


def auto_range(values: np.ndarray, mode: str) -> tuple[float, float]:
    v = np.asarray(values, dtype=np.float64).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (0.0, 1.0)
    lo, hi = float(v.min()), float(v.max())
    if mode == PERCENTILE:
        from ares.analysis.noise.panels import value_range

        frm, to = value_range(v, "percentile", (0.1, 99.9))
    elif mode in (MEAN_3_SIGMA, MEAN_5_SIGMA):
        k = 3.0 if mode == MEAN_3_SIGMA else 5.0
        m = float(v.mean())
        s = float(v.std(ddof=1)) if v.size > 1 else 0.0
        frm, to = m - k * s, m + k * s
    else:
        span = hi - lo
        frm, to = lo - PEAK_MARGIN * span, hi + PEAK_MARGIN * span
    if not (to - frm) > 1024 * float(np.spacing(max(abs(frm), abs(to)))):
        # constant data (or a spread no float histogram resolves: [5e-324, 0]): a unit-wide window
        frm, to = frm - 0.5, to + 0.5
    return frm, to


def bins_for(n: int, most: int = DEFAULT_BINS) -> int:
    """Bins for ``n`` values: about 2*sqrt(n), between 8 and ``most`` (a 20-column
    region gets 8 bins, not 64 mostly empty ones)."""
    return int(min(most, max(8, round(2 * math.sqrt(max(n, 0))))))


def histogram(values: np.ndarray, frm: float, to: float, bins: int = DEFAULT_BINS,
              integer: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(edges, counts) over [frm, to]. For integer data the bins are whole numbers of DN
    wide and centred on integers, so no bin is systematically empty."""
    v = np.asarray(values).ravel()
    if integer:
        width = max(1, math.ceil((to - frm) / bins))
        start = math.floor(frm) - 0.5
        n = max(1, math.ceil((to + 0.5 - start) / width))
        frm, to, bins = start, start + width * n, n
    # equal bins given as (count, range): numpy's direct binning, not a sort of the values
    counts, edges = np.histogram(v, bins=bins, range=(frm, to))
    return edges, counts


@dataclass(frozen=True)
class PanelState:
    """What a panel shows: its values (finite), range mode and From/To, histogram, numbers."""
    values: np.ndarray
    range_mode: str
    range: tuple[float, float]
    edges: np.ndarray
    counts: np.ndarray
    stats: PanelStats


def finite(values: np.ndarray | None) -> np.ndarray:
    v = np.zeros(0) if values is None else np.asarray(values).ravel()
    return v[np.isfinite(v)] if v.dtype.kind == "f" else v


def panel_state(v: np.ndarray, range_mode: str, manual: tuple[float, float], title: str, unit: str,
                bins: int) -> PanelState:
    """A panel's state for the finite values ``v`` (pure: runs in any thread)."""
    frm, to = manual if range_mode == MANUAL else auto_range(v, range_mode)
    integer = v.dtype.kind in "iu"
    edges, counts = histogram(v, frm, to, bins_for(v.size, bins), integer=integer)
    inside = v[(v >= frm) & (v <= to)].astype(np.float64) if v.size else np.zeros(0)
    stats = PanelStats()
    if inside.size:
        from ares.analysis.noise.panels import summarize

        p = summarize(title, inside, unit, range_mode="peak-to-peak", bins=8)
        stats = PanelStats(n=int(inside.size), mean=p.mean, sigma=p.sigma if inside.size > 1 else math.nan,
                           fitted_mean=p.fitted_mean, fitted_sigma=p.fitted_sigma, lowest=p.lowest,
                           highest=p.highest)
    return PanelState(v, range_mode, (float(frm), float(to)), edges, counts, stats)


class StatsPanelModel(Observable):
    """One panel: its values, display range, histogram and statistics."""

    def __init__(self, title: str, unit: str = "DN", bins: int = DEFAULT_BINS) -> None:
        super().__init__()
        self.title = title
        self.unit = unit
        self.bins = bins
        self.range_mode = PEAK_TO_PEAK
        self.values = np.zeros(0)
        self.range = (0.0, 1.0)
        self.edges = np.linspace(0.0, 1.0, bins + 1)
        self.counts = np.zeros(bins, dtype=np.int64)
        self.stats = PanelStats()

    # ---- inputs ---------------------------------------------------------------------
    def set_values(self, values: np.ndarray | None) -> None:
        self.show(self.job(values)())

    def job(self, values: np.ndarray | None):
        """The work of ``set_values(values)`` as a call for any thread (the range mode and
        From/To as they are now); ``show`` its result in this one."""
        mode, manual, title, unit, bins = self.range_mode, self.range, self.title, self.unit, self.bins
        return lambda: panel_state(finite(values), mode, manual, title, unit, bins)

    def show(self, state: PanelState) -> None:
        """Show ``state`` (from ``job``); a range chosen meanwhile is kept: recomputed here."""
        if state.range_mode != self.range_mode or (self.range_mode == MANUAL and state.range != self.range):
            state = panel_state(state.values, self.range_mode, self.range, self.title, self.unit, self.bins)
        self.values, self.range, self.edges, self.counts, self.stats = (
            state.values, state.range, state.edges, state.counts, state.stats)
        self._changed()

    def set_range_mode(self, mode: str) -> None:
        if mode not in RANGE_MODES:
            raise ValueError(f"unknown range mode {mode!r}")
        self.range_mode = mode
        self._recompute()

    def set_range(self, frm: float, to: float) -> None:
        """A hand-typed From/To (switches to Manual)."""
        if not to > frm:
            frm, to = min(frm, to), max(frm, to) + (0.0 if to != frm else 1.0)
        self.range_mode = MANUAL
        self.range = (float(frm), float(to))
        self._recompute()

    def restore(self) -> None:
        self.set_range_mode(PEAK_TO_PEAK)

    def clear(self) -> None:
        self.set_values(None)

    # ---- derived --------------------------------------------------------------------
    def _recompute(self) -> None:
        self.show(panel_state(self.values, self.range_mode, self.range, self.title, self.unit, self.bins))
