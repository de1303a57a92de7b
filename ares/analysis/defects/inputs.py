"""What the defect classifier reads, prepared: the dark statistics and their per-level flags, the dark-rate slope over several exposures, the flat's response, matched to its dark."""

from __future__ import annotations

import math
from typing import Sequence
import numpy as np
from ares.analysis.stats.median import fast_median
from ares.analysis.defects.dist import chi2_isf, chi2_ppf, trim_mean
from ares.analysis.defects.params import DefectThresholds
from ares.analysis.defects.limits import p_constant_codes, stuck_in_darks
from ares.analysis.defects.robust import block_median_background, local_background, remove_lines, robust_sigma, sampled_median, structure_ratio
from ares.analysis.defects.stats import PixelStats


def dequantized(res: np.ndarray, st: PixelStats) -> np.ndarray:
    """``res`` with a fixed-seed uniform dither of one code step (1/F DN for the mean of F
    integer frames) for the robust sigma only: the MAD of values on a lattice of 0.25 DN
    (4 frames) is off by up to ~15 %, and a sigma 10 % low turns a 4.8-sigma threshold
    into a 4.3-sigma one (10x the false alarms). The dither adds (1/F)^2/12 to the variance."""
    f = max(int(st.n_frames), 1)
    sample = st.mean.ravel()[:: max(st.mean.size // 4096, 1)] * f
    if not np.allclose(sample, np.round(sample), atol=1e-6):
        return res
    rng = np.random.default_rng(12345)
    return res + rng.uniform(-0.5 / f, 0.5 / f, res.shape)


class _Dark:
    """Per-level dark quantities (one exposure)."""

    def __init__(self, st: PixelStats, gain: float | None, th: DefectThresholds) -> None:
        self.st = st
        self.res, self.col_off, self.row_off, self.level = remove_lines(st.mean)
        # smooth or periodic structure left after the row/column medians (shading, glow,
        # a patterned dark) would hide hot pixels in its troughs and inflate sigma: take
        # it out with a local running median, only where it is there (skip otherwise)
        self.structure = structure_ratio(self.res)
        self.background_removed = self.structure > 1.1
        if self.background_removed:
            self.res = self.res - local_background(self.res)
        self.sigma = robust_sigma(dequantized(self.res, st), floor=1e-9)
        t = st.exposure_s
        self.rate_scale = gain * t if gain and t else None  # res / rate_scale: the excess dark rate, e-/s
        dof = st.n_frames - 1
        self.pop_var = sampled_median(st.var) / (chi2_ppf(0.5, dof) / dof)
        expected = self.pop_var + (gain * np.maximum(self.res, 0.0) if gain else 0.0)
        self.var_ratio = st.var / np.maximum(expected, 1e-12)
        del expected  # (a frame of float64: the classification of a 4096x3072 run keeps a dozen)
        # per-line temporal variance relative to the typical line: a 10 %-trimmed mean, not
        # a median -- with a pair of integer frames the variances take a few discrete
        # values and a line median jumps between them (false noisy lines at F = 2)
        cv = trim_mean(self.var_ratio, 0.1, axis=0)
        rv = trim_mean(self.var_ratio, 0.1, axis=1)
        self.col_var = cv / max(float(np.median(cv)), 1e-12)
        self.row_var = rv / max(float(np.median(rv)), 1e-12)
        self.stuck_ok, self.stuck_why = stuck_in_darks(math.sqrt(self.pop_var), st.n_frames, th.max_false_alarm)


def _level_flags(d: "_Dark", var: np.ndarray, th: DefectThresholds, rate_mode: bool, hot_n, warm_n, hot_stat) -> None:
    """One dark level's hot/warm votes: its excess over the noise of its averaged excess
    (``var``, consumed), above the rate thresholds (with K and t) or the z ones. Without a
    rate a z-warm pixel must not show a raised temporal variance (p = 0.01): a trap that
    switches over a few frames raises the mean as a warm pixel does, and its variance with
    it; such a pixel is left to the RTS test."""
    np.sqrt(var, out=var)
    z = np.divide(d.res, var, out=var)
    sig = z > th.warm_z
    if rate_mode:
        rate = d.res / d.rate_scale
        hot = sig & (rate > th.hot_e_per_s)
        warm = sig & (rate > th.warm_e_per_s) & ~hot
        np.maximum(hot_stat, rate, out=hot_stat)
    else:
        dof = d.st.n_frames - 1
        hot = z > th.hot_z
        warm = sig & ~hot & (d.var_ratio <= chi2_isf(0.01, dof) / dof)
        np.maximum(hot_stat, z, out=hot_stat)
    hot_n += hot
    warm_n += warm


class _Slope:
    """Per-pixel weighted least-squares slope of the dark excess over the exposure times
    (weights 1 / the variance of each level's averaged excess): the dark rate in DN/s."""

    def __init__(self, shape) -> None:
        self.s = [np.zeros(shape) for _ in range(5)]  # sum w, w t, w t^2, w r, w t r

    def add(self, d: "_Dark", var: np.ndarray) -> None:
        t = float(d.st.exposure_s)
        w = np.divide(1.0, var, out=var)
        sw, swt, swtt, swr, swtr = self.s
        sw += w
        swt += w * t
        swtt += w * (t * t)
        w *= d.res
        swr += w
        swtr += w * t

    def flags(self, th: DefectThresholds, gain: float):
        sw, swt, swtt, swr, swtr = self.s
        det = sw * swtt - swt * swt
        slope = (sw * swtr - swt * swr) / det
        z = slope / np.sqrt(sw / det)
        rate = slope / gain
        sig = z > th.warm_z
        hot = sig & (rate > th.hot_e_per_s)
        return hot, sig & (rate > th.warm_e_per_s) & ~hot, rate

    @staticmethod
    def se0(D) -> float:
        """The slope's SE (DN/s) for a pixel with the population's noise at every level."""
        w = np.array([1.0 / d.sigma**2 for d in D])
        t = np.array([float(d.st.exposure_s) for d in D])
        return float(np.sqrt(w.sum() / (w.sum() * (w * t * t).sum() - (w * t).sum() ** 2)))


class _Flat:
    """Per-level response (flat minus dark) relative to the local median response."""

    def __init__(self, st: PixelStats, dark: PixelStats, block: int, max_false_alarm: float) -> None:
        self.st = st
        resp = st.mean - dark.mean
        self.median = sampled_median(resp)
        self.resp = resp
        self.bg = block_median_background(resp, block)
        # where the local response is not positive the ratio is undefined: 1 (neutral)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.ratio = resp / self.bg
        self.ratio[~(self.bg > 0)] = 1.0
        # the deviation must be significant against the noise of the two averaged means
        # (made in place: a 4096x3072 level would hold three frames of float64 more)
        self.noise = st.var / st.n_frames
        self.noise += dark.var / dark.n_frames
        np.sqrt(self.noise, out=self.noise)
        self.col_ratio = fast_median(self.ratio, axis=0)
        self.row_ratio = fast_median(self.ratio, axis=1)
        # zero variance is a stuck pixel here only where a normal pixel's shot noise makes
        # equal codes in every frame improbable
        self.pop_sigma = math.sqrt(max(sampled_median(st.var), 0.0))
        self.stuck_ok = p_constant_codes(self.pop_sigma, st.n_frames) <= max_false_alarm


def _levels(x: PixelStats | Sequence[PixelStats] | None) -> list[PixelStats]:
    if x is None:
        return []
    if isinstance(x, PixelStats):
        return [x]
    return list(x)


def _match_dark(flat: PixelStats, darks: list[PixelStats]) -> PixelStats:
    if flat.exposure_s is not None:
        known = [d for d in darks if d.exposure_s is not None]
        if known:
            return min(known, key=lambda d: abs(d.exposure_s - flat.exposure_s))
    return darks[0]


def _need(n: int, fraction: float) -> int:
    return max(1, int(math.ceil(fraction * n - 1e-9)))
