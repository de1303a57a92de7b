"""ARES result panels: Mean Signal, Noise, Columns and Rows of one region/channel.

Each panel summarizes a set of values (pixel means, pixel temporal sigmas, column means,
row means) with Mean, Sigma, Fitted Mean, Fitted Sigma (a Gaussian fitted to the core of
the histogram, robust to defect tails), Lowest, Highest (range mode ``"peak-to-peak"``
or ``"percentile"`` with ``percentiles=(0.1, 99.9)``), the histogram, and the profile or
map it came from. ``pixel_gain_map`` gives per-pixel conversion gain from a per-pixel
photon-transfer fit over several (flat, dark) levels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ares.errors import InputError

from ares.analysis.noise.accumulate import StackAccumulator

__all__ = ["Panel", "summarize", "robust_gauss_fit", "value_range", "result_panels", "pixel_gain_map"]

MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class Panel:
    name: str
    unit: str
    mean: float
    sigma: float
    fitted_mean: float
    fitted_sigma: float
    lowest: float
    highest: float
    range_mode: str
    counts: np.ndarray = field(repr=False)
    edges: np.ndarray = field(repr=False)
    data: np.ndarray = field(repr=False)  # profile (1-D) or map (2-D) the values came from

    def as_dict(self) -> dict:
        return {k: getattr(self, k) for k in
                ("name", "unit", "mean", "sigma", "fitted_mean", "fitted_sigma", "lowest", "highest", "range_mode")}


def value_range(values: np.ndarray, mode: str = "peak-to-peak", percentiles=(0.1, 99.9)) -> tuple[float, float]:
    v = np.asarray(values, np.float64).ravel()
    if mode == "peak-to-peak":
        return float(v.min()), float(v.max())
    if mode == "percentile":
        lo, hi = np.percentile(v, percentiles)
        return float(lo), float(hi)
    raise InputError(f"range mode must be 'peak-to-peak' or 'percentile', not {mode!r}")


def robust_gauss_fit(values: np.ndarray, bins: int = 128) -> tuple[float, float]:
    """Gaussian (mean, sigma) fitted to the histogram core.

    Start from median and 1.4826*MAD, histogram the values within +-4 robust sigma,
    fit a Gaussian (``lsq.levenberg_marquardt``, Poisson weights) to the bins above 5 % of
    the peak. Falls back to the robust start when the fit fails or the data have (almost)
    no spread.
    """
    from ares.analysis.stats.lsq import levenberg_marquardt

    v = np.asarray(values, np.float64).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan, math.nan
    med = float(np.median(v))
    mad = float(np.median(np.abs(v - med))) * MAD_TO_SIGMA
    if mad == 0 or v.size < 20:
        sd = float(v.std())
        return med, (mad if mad > 0 else sd)
    lo, hi = med - 4 * mad, med + 4 * mad
    core = v[(v >= lo) & (v <= hi)]
    counts, edges = np.histogram(core, bins=min(bins, max(8, core.size // 10)), range=(lo, hi))
    centers = 0.5 * (edges[1:] + edges[:-1])
    keep = counts > 0.05 * counts.max()
    if keep.sum() < 4:
        return med, mad

    x, y = centers[keep], counts[keep].astype(np.float64)

    def g(p):
        return p[0] * np.exp(-0.5 * ((x - p[1]) / p[2]) ** 2)

    with np.errstate(all="ignore"):
        fit = levenberg_marquardt(g, y, np.sqrt(y + 1.0), np.array([y.max(), med, mad]))
    if fit is None:
        return med, mad
    mu, s = float(fit[0][1]), abs(float(fit[0][2]))
    if not (lo <= mu <= hi) or not (0.2 * mad <= s <= 5 * mad):
        return med, mad
    return mu, s


def summarize(name: str, data: np.ndarray, unit: str = "DN", range_mode: str = "peak-to-peak",
              percentiles=(0.1, 99.9), bins: int = 256) -> Panel:
    v = np.asarray(data, np.float64).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        raise InputError(f"panel '{name}': no finite values")
    lo, hi = value_range(v, range_mode, percentiles)
    fm, fs = robust_gauss_fit(v)
    # A range narrower than a few float steps at this magnitude cannot hold `bins` bins
    # (numpy raises); such data are constant for display purposes: centre a unit range.
    if not hi - lo > 4 * bins * np.spacing(max(abs(lo), abs(hi))):
        mid = 0.5 * (lo + hi)
        lo_h, hi_h = mid - 0.5, mid + 0.5
    else:
        lo_h, hi_h = lo, hi
    counts, edges = np.histogram(v, bins=bins, range=(lo_h, hi_h))
    return Panel(name, unit, float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0, fm, fs, lo, hi,
                 range_mode, counts, edges, np.asarray(data))


def result_panels(acc: StackAccumulator, range_mode: str = "peak-to-peak", percentiles=(0.1, 99.9),
                  bins: int = 256, dark: StackAccumulator | None = None) -> dict[str, Panel]:
    """Mean Signal, Noise, Columns, Rows panels of one region/channel.

    With ``dark`` the signal is dark-subtracted (photo-signal). Noise is the per-pixel
    temporal sigma (ddof=1; needs >= 2 frames). Columns/Rows summarize the column and
    row mean profiles.
    """
    sig = acc.mean_map() - (dark.mean_map() if dark is not None else 0.0)
    kw = dict(range_mode=range_mode, percentiles=percentiles, bins=bins)
    out = {"Mean Signal": summarize("Mean Signal", sig, **kw)}
    if acc.n_frames >= 2:
        out["Noise"] = summarize("Noise", np.sqrt(acc.temporal_var_map()), **kw)
    out["Columns"] = summarize("Columns", sig.mean(axis=0), **kw)
    out["Rows"] = summarize("Rows", sig.mean(axis=1), **kw)
    return out


def pixel_gain_map(levels, min_levels: int = 2) -> np.ndarray:
    """Per-pixel conversion gain (DN/e-) from a per-pixel PTC over several levels.

    ``levels`` is a sequence of (flat_acc, dark_acc) pairs. For each pixel the temporal
    variance difference V is regressed on the signal S through the origin
    (``K = sum(S V) / sum(S^2)``), as the EMVA photon-transfer line.
    """
    levels = list(levels)
    if len(levels) < min_levels:
        raise InputError(f"a per-pixel gain map needs >= {min_levels} illumination levels, got {len(levels)}")
    num = den = 0.0
    for flat, dark in levels:
        s = flat.mean_map() - dark.mean_map()
        v = flat.temporal_var_map() - dark.temporal_var_map()
        num = num + s * v
        den = den + s * s
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, np.nan)
