"""The dark mean against exposure with the offset drifting on the bench's clock.

A black level that drifts while a dark sweep is taken (the die warming after power-up, the
clamp, the chamber's regulation) adds to the slope of the dark mean against exposure
whatever the order: taken in increasing exposure the drift *is* a slope, and no residual
shows it. The frames tell it apart where they can: each frame's mean, read out at a known
time ``tau`` on the bench's clock, is modelled as::

    mean = offset + rate * exposure + drift * tau

fitted on every frame (``drift_fit``). Inside a stack the exposure is fixed, so the trend of
its frame means with their times measures the drift independently of the exposure (the
within-stack slopes, pooled); between the stacks the levels' means measure offset + rate *
exposure + drift * their time, which separates the two where the exposures were not taken in
the clock's order (shuffled). The decision is made on the measured frame-to-frame scatter
(the stacks' frame means about their own trends): the drift term is kept where an F-test on
it gives p < ``DRIFT_P``; the levels' residuals about the joint fit are checked against that
scatter as in ``dark_current._mean_slope``.

Where the exposures follow the clock (their r^2 with the stacks' times >= ``CLOCK_R2``), a kept
drift term's correction rests on the drift being one straight line over the whole sweep,
measured only inside the stacks: the rate is then reported, but ``separable`` is False and
``why`` says what to do (take the exposures in shuffled order -- ``<sweep order="shuffled">``
-- or bracket the sweep with reference darks at one exposure).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.ptc.fit import residual_se_widening

DRIFT_P = 0.01  # the drift term is kept where its F-test on the frames' scatter says so at this probability
CLOCK_R2 = 0.8  # the exposures "follow the clock": r^2 of exposure against the stacks' mean times at or above


@dataclass(frozen=True)
class DriftFit:
    slope: float  # DN/s of exposure, the drift term kept or not
    slope_se: float
    intercept: float  # DN at exposure 0 (at the sweep's mean time when the drift is kept)
    intercept_se: float
    drift: float  # DN/s of clock time (the joint fit's, kept or not)
    drift_se: float
    p: float  # its F-test probability on the frames' scatter
    kept: bool  # the drift term is in the reported rate
    follows_clock: float  # r^2 of the exposures against the stacks' mean times
    shift_per_drift: float  # s of clock per s of exposure: a drift of d DN/s moves a rate fitted without it by d * this
    how: str

    @property
    def separable(self) -> bool:
        """The rate is not confounded with the drift: no drift term kept, or the order separates them."""
        return not self.kept or self.follows_clock < CLOCK_R2

    @property
    def why(self) -> str:
        """Why a kept drift could not be separated from the dark current, and what to do ('' if it could)."""
        if self.separable:
            return ""
        return (f"the offset drifts ({self.drift:.3g} ± {self.drift_se:.2g} DN/s of clock, F-test p {self.p:.2g}) and "
                f"the exposures were taken in the clock's order (r^2 {self.follows_clock:.2f}): the drift moves the "
                f"slope by {self.drift * self.shift_per_drift:+.3g} DN/s, corrected only as far as the drift is one "
                "straight line measured inside the stacks -- take the exposures in shuffled order "
                "(<sweep order=\"shuffled\">) or bracket the sweep with reference darks at one exposure")


def _usable(t_exp, frame_means, frame_times):
    """[(exposure, frame means, their times)] of the levels with >= 2 frames with finite means and times."""
    out = []
    for e, fm, ft in zip(t_exp, frame_means, frame_times):
        if fm is None or ft is None or not math.isfinite(e):
            continue
        y, tau = np.asarray(fm, float), np.asarray(ft, float)
        if y.shape != tau.shape:
            continue
        ok = np.isfinite(y) & np.isfinite(tau)
        if ok.sum() >= 2:
            out.append((float(e), y[ok], tau[ok]))
    return out


def drift_fit(t_exp, frame_means, frame_times) -> DriftFit | None:
    """The joint fit of every frame's mean (``frame_means[k]``, DN) read out at ``frame_times[k]``
    (s on the bench's clock) of the levels at exposure ``t_exp[k]`` (s); None where the frames
    cannot measure a drift (fewer than 3 levels with 2 timed frames, no spread of times inside the
    stacks, no degrees of freedom left for their scatter)."""
    lv = _usable(np.asarray(t_exp, float), frame_means, frame_times)
    n_lv = len(lv)
    N = sum(y.size for _, y, _ in lv)
    dof_w = N - n_lv - 1  # the frames' scatter about their stacks' means and the common drift
    if n_lv < 3 or dof_w < 1:
        return None
    t0 = float(np.mean(np.concatenate([tau for _, _, tau in lv])))  # (times about their mean: conditioning)
    e = np.array([x[0] for x in lv])
    n = np.array([x[1].size for x in lv], float)
    ybar = np.array([x[1].mean() for x in lv])
    tbar = np.array([x[2].mean() for x in lv]) - t0
    s_tt = sum(float(((tau - tau.mean()) ** 2).sum()) for _, _, tau in lv)
    s_ty = sum(float(((tau - tau.mean()) * (y - y.mean())).sum()) for _, y, tau in lv)
    s_yy = sum(float(((y - y.mean()) ** 2).sum()) for _, y, _ in lv)
    if not s_tt > 0:
        return None
    d_w = s_ty / s_tt  # the drift inside the stacks, pooled (the exposure is fixed in each)
    s2 = max(s_yy - d_w * s_ty, 0.0) / dof_w  # one frame mean's scatter about its stack's trend, DN^2
    if not s2 > 0:
        return None
    # the levels' means and the within-stack drift as independent observations (weights in 1/s2 units):
    # the same as the least-squares fit on every frame
    X = np.vstack([np.column_stack([np.ones(n_lv), e, tbar]), [0.0, 0.0, 1.0]])
    y = np.concatenate([ybar, [d_w]])
    w = np.concatenate([n, [s_tt]])
    A = X.T @ (X * w[:, None])
    try:
        cov = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        return None
    beta = cov @ (X.T @ (w * y))
    r = (y - X @ beta) * np.sqrt(w)
    dof_l = n_lv - 2  # (n_lv + 1 observations, 3 parameters)
    chi2 = float(r @ r) / max(dof_l, 1)
    from ares.analysis.stats.tails import f_sf

    p_lv = f_sf(dof_l, dof_w, chi2) if chi2 > 1 and dof_l >= 1 else 1.0
    if p_lv < DRIFT_P:  # the levels scatter about the joint fit more than their frames do: the residuals win
        scale, dof, how = s2 * chi2, dof_l, (f"the levels scatter about the joint fit {math.sqrt(chi2):.2g}x more "
                                             f"than their frames do (F-test p {p_lv:.2g}): SE from the residuals")
    else:
        scale, dof, how = s2, dof_w, f"SE from the stacks' frame scatter about their trends ({math.sqrt(s2):.2g} DN a frame)"
    wid = residual_se_widening(dof)
    se = np.sqrt(np.diag(cov) * scale)
    drift, drift_se = float(beta[2]), float(se[2])
    p = f_sf(1, dof, (drift / drift_se) ** 2) if drift_se > 0 else 1.0
    ww = n / n.sum()
    ec, tc = e - ww @ e, tbar - ww @ tbar
    sxx, syy, sxy = float(ww @ (ec * ec)), float(ww @ (tc * tc)), float(ww @ (ec * tc))
    r2 = sxy * sxy / (sxx * syy) if sxx > 0 and syy > 0 else 1.0
    shift = sxy / sxx if sxx > 0 else math.nan
    return DriftFit(float(beta[1]), float(se[1]) * wid, float(beta[0]), float(se[0]) * wid, drift, drift_se * wid,
                    float(p), bool(p < DRIFT_P), float(r2), float(shift),
                    f"{how}, x Student's t ({dof} dof: x {wid:.3g}); offset + rate x exposure + drift x clock time "
                    f"fitted on every frame (drift {drift:.3g} ± {drift_se * wid:.2g} DN/s, F-test p {p:.2g})")
