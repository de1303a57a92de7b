"""The linearity turnoff of a ramp without variances (issue 48).

``ramp_turnoff``: a linearity ramp without variances (mean signal against exposure time
or monitor-photodiode charge): LSST cp_pipe ``cpLinearitySolve._computeTurnoffAndMax``
(after eo_pipe's linearity task) -- a line through the origin with chi-square weights
``1/signal`` over levels above ``min_signal``, relative residuals minus their median;
the turnoff is the last level, in illumination order, before the first that deviates by
more than 1 % (confirmed by the next one: a single wild level does not end the ramp),
and the maximum signal is the median of the levels within 1 % of the brightest.
EMVA 1288 4.0 Linear Section 6.6 takes saturation from the histogram (0.2 % of samples
at the maximum code), which a ramp of means cannot show; this rule needs no errors.

Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.median import fast_median
from ares.analysis.ptc.fit import residual_se_widening


@dataclass(frozen=True)
class RampTurnoff:
    index: int  # input index of the turnoff level (-1: none)
    turnoff: float  # signal at the turnoff (the input's unit)
    max_signal: float
    reached: bool  # a level beyond the turnoff deviates (else the turnoff is the brightest level)
    slope: float
    note: str
    max_signal_se: float = math.nan  # the plateau levels' own scatter (median's SE); 1 level: the 1 % window / sqrt(3)


def ramp_turnoff(x, y, min_signal: float = 1000.0, tol: float = 0.01, mask=None) -> RampTurnoff:
    """Linearity turnoff and maximum signal of a ramp: signal ``y`` against an illumination
    ``x`` (exposure time or photodiode charge), in any order (see the module docstring).
    ``mask``: levels known to be below saturation for the initial line (default: all)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    fin = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if fin.sum() < 4:
        return RampTurnoff(-1, math.nan, math.nan, False, math.nan,
                           f"{int(fin.sum())} usable levels: a ramp needs >= 4 with positive illumination and signal")
    floor = min_signal if (y[fin] >= min_signal).sum() >= 4 else 0.0
    fit = fin & (y >= floor)
    if mask is not None:
        fit &= np.asarray(mask, bool)
    if fit.sum() < 4:
        fit = fin
    order = np.flatnonzero(fin)[np.argsort(x[fin], kind="stable")]
    for _ in range(int(fit.sum())):
        slope = float(np.sum(x[fit]) / np.sum(x[fit] ** 2 / y[fit]))  # chi2 line through 0, variance = signal
        r = np.full(y.size, math.nan)
        r[fin] = (y[fin] - slope * x[fin]) / y[fin]
        r -= float(fast_median(r[fit]))
        bad = np.abs(r) >= tol
        last = -1
        for k, i in enumerate(order):
            if y[i] < floor:
                continue
            if bad[i] and (k + 1 == order.size or bad[order[k + 1]]):
                break
            last = int(i)
        if last >= 0 and (np.abs(r[fit]) < tol).sum() > 4:
            break
        worst = np.flatnonzero(fit)[np.argmax(np.abs(r[fit]))]  # a bad initial line: drop its worst level
        fit[worst] = False
        if fit.sum() < 4:
            break
    if last < 0:
        return RampTurnoff(-1, math.nan, math.nan, False, math.nan,
                           "no line through the origin describes the ramp within 1 %")
    ymax = float(np.max(y[fin]))
    reached = bool(y[last] < ymax and (x[fin] > x[last]).any())
    top = fin & (y > (1 - tol) * ymax)
    mx = float(fast_median(y[top])) if reached else float(y[last])
    nt = int(top.sum())
    # its SE: the plateau's own scatter (median of nt levels, Student's t); one or two: the window / sqrt(3)
    mx_se = (1.2533 * float(np.std(y[top], ddof=1)) / math.sqrt(nt) * residual_se_widening(nt - 1) if nt >= 3
             else tol * ymax / math.sqrt(3))
    note = (f"linearity turnoff (LSST cp_pipe cpLinearitySolve rule): last level before the first two deviating "
            f"> {100 * tol:g} % from a line through the origin fitted above {floor:g}; maximum signal: median of "
            f"the levels within {100 * tol:g} % of the brightest")
    if not reached:
        note = "no level deviates beyond the turnoff: the ramp does not reach saturation (a lower limit)"
    return RampTurnoff(last, float(y[last]), mx, reached, slope, note, mx_se)
