"""Image lag: signal left in the first dark frame after a bright one, in % of the
bright signal (both above the settled dark level).

``lag = (mu_first_dark - mu_dark) / (mu_bright - mu_dark)``. Its SE comes from the
scatter over repeated bright->dark cycles when there are at least 3 (with Student's t for
their n - 1 degrees of freedom), otherwise from the
pixel scatter of the first dark frame (which ignores frame-global temporal noise --
stated in the note).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.analysis.ptc.fit import residual_se_widening


@dataclass(frozen=True)
class LagResult:
    lag_pct: Estimate
    bright_signal_dn: float
    cycles: int


def image_lag(bright: np.ndarray, first_dark: np.ndarray, dark: np.ndarray) -> LagResult:
    """``bright``: settled bright frames; ``first_dark``: the first dark frame of each
    cycle (cycles, rows, cols) or one frame; ``dark``: settled dark frames."""
    b = np.asarray(bright, float)
    fd = np.asarray(first_dark, float)
    d = np.asarray(dark, float)
    if fd.ndim == 2:
        fd = fd[None]
    mu_d = float(d.mean())
    sig = float(b.mean()) - mu_d
    floor = 10 * float(d.std()) / math.sqrt(d[0].size if d.ndim == 3 else d.size)
    if not sig > floor:
        return LagResult(Estimate.na("no bright signal above dark", "%"), sig, fd.shape[0])
    per = (fd.reshape(fd.shape[0], -1).mean(axis=1) - mu_d) / sig
    val = 100 * float(per.mean())
    if fd.shape[0] >= 3:  # the cycles' scatter on n - 1 dof: Student's t (issue 48)
        w = residual_se_widening(per.size - 1)
        se = 100 * float(per.std(ddof=1)) / math.sqrt(per.size) * w
        note = f"mean over {per.size} bright->dark cycles; SE from their scatter x Student's t ({per.size - 1} dof: x {w:.3g})"
    else:
        dark_img = d.reshape(-1, *fd.shape[1:]).mean(axis=0) if d.ndim == 3 else d
        diff = fd - dark_img
        se = 100 * float(diff.std(ddof=1)) / math.sqrt(diff.size) / sig
        note = "SE from pixel scatter (frame-global noise not included: use >= 3 cycles)"
    return LagResult(Estimate(val, se, "%", note), sig, per.size)


def lag_from_sequence(frames: np.ndarray, lit, settle: int = 2) -> LagResult:
    """Lag from one frame sequence with a per-frame ``lit`` flag (True = illuminated).

    Bright frames count once ``settle`` frames after a dark->bright switch; first dark
    frames are those right after a bright->dark switch; settled dark frames are those at
    least ``settle`` frames after it."""
    f = np.asarray(frames)
    lit = np.asarray(lit, bool)
    if f.shape[0] != lit.size:
        raise ValueError("one lit flag per frame is required")
    since = np.zeros(lit.size, int)
    for i in range(1, lit.size):
        since[i] = since[i - 1] + 1 if lit[i] == lit[i - 1] else 0
    first = [i for i in range(1, lit.size) if not lit[i] and lit[i - 1]]
    bright = lit & (since >= settle)
    dark = ~lit & (since >= settle)
    if not first or not bright.any() or not dark.any():
        na = "sequence needs settled bright frames, a bright->dark switch and settled dark frames"
        return LagResult(Estimate.na(na, "%"), math.nan, 0)
    return image_lag(f[bright], f[first], f[dark])
