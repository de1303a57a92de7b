"""Defective-pixel identification and counting (hot, warm, dead, low/high response, stuck,
noisy, RTS, bad columns/rows, clusters) -- pure numpy/scipy, every threshold a parameter.

Typical use on recorded stacks::

    from ares.analysis.defects import classify_stack, DefectThresholds
    res = classify_stack(dark_stack, flat_stack, gain_dn_per_e=0.5, exposure_s=0.1)
    res.counts, res.defects, res.mask, res.histograms, res.passed

From streaming statistics (two passes)::

    res1 = classify_defects(PixelStats(mean, var, n, exposure_s))   # pass 1
    col = SeriesCollector(*res1.rts_candidates)                       # pass 2: feed frames
    res = classify_defects(PixelStats(...), rts_series=col)
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from ares.errors import InputError

from ares.analysis.defects.params import DefectThresholds
from ares.analysis.defects.result import BITS, PIXEL_CLASSES, DefectResult
from ares.analysis.defects.stats import PixelStats, SeriesCollector, candidate_series, masked_population_stats, pixel_stats

__all__ = [
    "BITS", "PIXEL_CLASSES", "DefectResult", "DefectThresholds", "PixelStats", "SeriesCollector",
    "candidate_series", "classify_defects", "classify_regions", "classify_stack",
    "masked_population_stats", "pixel_stats",
]

Region = tuple[slice, slice]


def classify_defects(*args, **kwargs) -> DefectResult:
    """``ares.analysis.defects.classify.classify_defects``, imported on first use: it needs
    scipy, and parsing thresholds (``ares validate``) must not load it."""
    from ares.analysis.defects.classify import classify_defects as classify

    return classify(*args, **kwargs)


def _as_list(x) -> list:
    if x is None:
        return []
    if isinstance(x, np.ndarray) and x.ndim == 3:
        return [x]
    return list(x)


def _exposures(exposure_s, n: int) -> list:
    if exposure_s is None or np.isscalar(exposure_s):
        return [exposure_s] * n
    e = list(exposure_s)
    if len(e) != n:
        raise ValueError(f"{len(e)} exposure times for {n} stacks")
    return e


def classify_stack(
    dark: np.ndarray | Sequence[np.ndarray],
    flat: np.ndarray | Sequence[np.ndarray] | None = None,
    *,
    gain_dn_per_e: float | None = None,
    exposure_s: float | Sequence[float] | None = None,
    flat_exposure_s: float | Sequence[float] | None = None,
    thresholds: DefectThresholds | None = None,
    regions: Mapping[str, Region] | None = None,
) -> DefectResult | dict[str, DefectResult]:
    """Both passes on recorded (F, R, C) stacks: statistics, then RTS on the candidates.

    ``dark``/``flat``: one stack or a list of stacks (levels); the RTS series come from
    the first dark stack. With ``regions`` ({name: (row_slice, col_slice)}, steps allowed
    for colour channels) the result is a dict per region.
    """
    darks = _as_list(dark)
    flats = _as_list(flat)
    dstats = [pixel_stats(s, e) for s, e in zip(darks, _exposures(exposure_s, len(darks)))]
    fexp = flat_exposure_s if flat_exposure_s is not None else (
        exposure_s if exposure_s is None or np.isscalar(exposure_s) else None)
    fstats = [pixel_stats(s, e) for s, e in zip(flats, _exposures(fexp, len(flats)))]
    series_stack = darks[0]
    if regions is None:
        return classify_defects(dstats, fstats, gain_dn_per_e=gain_dn_per_e, thresholds=thresholds,
                                rts_series=lambda r, c: series_stack[:, r, c])
    return classify_regions(dstats, fstats, regions, gain_dn_per_e=gain_dn_per_e, thresholds=thresholds,
                            rts_series=lambda r, c: series_stack[:, r, c])


def classify_regions(
    dark: PixelStats | Sequence[PixelStats],
    flats: PixelStats | Sequence[PixelStats] | None,
    regions: Mapping[str, Region],
    *,
    gain_dn_per_e: float | None = None,
    thresholds: DefectThresholds | None = None,
    rts_series=None,
) -> dict[str, DefectResult]:
    """Classify each region/channel separately.

    ``rts_series``: a callable taking full-frame (rows, cols), or a full-frame
    :class:`SeriesCollector` (each region gets its own pixels of it).
    """
    darks = [dark] if isinstance(dark, PixelStats) else list(dark)
    fl = [] if flats is None else ([flats] if isinstance(flats, PixelStats) else list(flats))
    out = {}
    shape = darks[0].shape
    for name, (rs, cs) in regions.items():
        r0, _, rstep = rs.indices(shape[0])
        c0, _, cstep = cs.indices(shape[1])
        if not (len(range(shape[0])[rs]) and len(range(shape[1])[cs])):
            raise InputError(f"region '{name}' holds no pixel of a {shape[1]}x{shape[0]} frame")
        series = None
        if isinstance(rts_series, SeriesCollector):
            series = rts_series.region(rs, cs, shape)
        elif rts_series is not None:
            series = (lambda r, c, r0=r0, c0=c0, rstep=rstep, cstep=cstep:
                      rts_series(r0 + rstep * r, c0 + cstep * c))
        out[name] = classify_defects(
            [d.region(rs, cs) for d in darks], [f.region(rs, cs) for f in fl],
            gain_dn_per_e=gain_dn_per_e, thresholds=thresholds, rts_series=series,
            origin=(r0, c0), step=(rstep, cstep))
    return out
