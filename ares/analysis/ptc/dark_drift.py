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
it gives p < ``DRIFT_P`` -- in the joint fit, or on the stacks' own trends alone (a curved drift
scatters the levels about the joint fit and widens its SEs, not those; the smaller p of the two,
doubled); the levels' residuals
about the joint fit are checked against that scatter as in ``dark_current._mean_slope``.

A drift the frames show is fitted as a parabola in time: a warm-up is curved, and a line through it leaves its curvature in the rate wherever the order is
not random (a 3 DN warm-up bracketed by reference darks: +1.9 SE median with a line, +0.0 with
the parabola, benchmarks/dark_drift.md). Where the exposures follow the clock (their r^2 on the
stacks' drift terms >= ``CLOCK_R2``), a kept drift's correction rests on that curve holding over
the whole sweep, measured only inside the stacks: the rate is then reported, but ``separable`` is False and
``why`` says what to do (take the exposures in shuffled order -- ``<axis order="shuffled">``
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
                f"slope by about {self.drift * self.shift_per_drift:+.3g} DN/s, corrected only as far as the drift follows "
                "the curve the frames measure inside the stacks -- take the exposures in shuffled order "
                "(<axis order=\"shuffled\">) or bracket the sweep with reference darks at one exposure")


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


def _ols(X, y):
    """(coefficients, (X^T X)^-1, residual sum of squares) of y on X; None if X is singular."""
    A = X.T @ X
    try:
        cov = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(cov)) or np.linalg.cond(A) > 1e12:
        return None
    beta = cov @ (X.T @ y)
    r = y - X @ beta
    return beta, cov, float(r @ r)


def _fit(lv, degree: int, t0: float, ts: float):
    """The joint fit with a drift polynomial of ``degree`` in clock time, on every frame: (coefficients
    [offset, rate, drift terms per (ts s)^k], their covariance, dof, how the SEs were decided, F-test
    probability of the drift terms); None where it cannot be made."""
    y = np.concatenate([f for _, f, _ in lv])
    e = np.concatenate([np.full(f.size, x) for x, f, _ in lv])
    tau = np.concatenate([(t - t0) / ts for _, _, t in lv])
    drift = np.column_stack([tau ** (k + 1) for k in range(degree)])
    k_lv, N = len(lv), y.size
    stage = np.zeros((N, k_lv))
    stage[np.arange(N), np.repeat(np.arange(k_lv), [f.size for _, f, _ in lv])] = 1.0
    dof_w = N - k_lv - degree  # the frames' scatter about their stacks' means and the common drift
    within = _ols(np.column_stack([stage, drift]), y) if dof_w >= 1 else None
    joint = _ols(np.column_stack([np.ones(N), e, drift]), y)
    if within is None or joint is None or not within[2] > 0:
        return None
    beta, cov, rss = joint
    s2 = within[2] / dof_w  # one frame mean's scatter about its stack's trend, DN^2
    dof_l = k_lv - 2  # the levels' means about the joint fit (it is nested in the within fit)
    chi2 = max(rss - within[2], 0.0) / max(dof_l, 1) / s2
    from ares.analysis.stats.tails import f_sf

    p_lv = f_sf(dof_l, dof_w, chi2) if chi2 > 1 and dof_l >= 1 else 1.0
    if p_lv < DRIFT_P:  # the levels scatter about the joint fit more than their frames do: the residuals win
        scale, dof, how = s2 * chi2, dof_l, (f"the levels scatter about the joint fit {math.sqrt(chi2):.2g}x more "
                                             f"than their frames do (F-test p {p_lv:.2g}): SE from the residuals")
    else:
        scale, dof, how = s2, dof_w, f"SE from the stacks' frame scatter about their trends ({math.sqrt(s2):.2g} DN a frame)"
    cov = cov * scale
    b, c = beta[2:], cov[2:, 2:]
    p_all = f_sf(degree, dof, float(b @ np.linalg.solve(c, b)) / degree)
    # the stacks' own trends alone (exposure fixed in each; a curved drift scattering the levels about the
    # joint fit widens its SEs, not these): the drift terms against the frames' scatter
    bw, cw = within[0][k_lv:], within[1][k_lv:, k_lv:] * s2
    p_within = f_sf(degree, dof_w, float(bw @ np.linalg.solve(cw, bw)) / degree)
    return beta, cov, dof, how, min(1.0, 2 * min(p_all, p_within))  # (two tests, one decision: Bonferroni)


def drift_fit(t_exp, frame_means, frame_times) -> DriftFit | None:
    """The joint fit of every frame's mean (``frame_means[k]``, DN) read out at ``frame_times[k]``
    (s on the bench's clock) of the levels at exposure ``t_exp[k]`` (s); None where the frames
    cannot measure a drift (fewer than 3 levels with 2 timed frames, no spread of times inside the
    stacks, no degrees of freedom left for their scatter). No drift seen: a line in time (its figures
    for the note); a drift seen: a parabola; ``drift`` is its rate at the sweep's mean time."""
    lv = _usable(np.asarray(t_exp, float), frame_means, frame_times)
    if len(lv) < 3:
        return None
    t_all = np.concatenate([t for _, _, t in lv])
    t0 = float(t_all.mean())  # (times about their mean, in units of their spread: conditioning)
    ts = float(np.abs(t_all - t0).max())
    if not ts > 0:
        return None
    fit = _fit(lv, 1, t0, ts)
    if fit is None:
        return None
    p = fit[4]  # the drift seen or not: the line's test (joint and within-stack, one decision)
    curved = _fit(lv, 2, t0, ts) if p < DRIFT_P else None
    # a drift seen is fitted as a parabola: a warm-up is curved, and a straight line through it leaves its
    # curvature in the rate wherever the order is not random
    degree = 2 if curved is not None else 1
    beta, cov, dof, how, _ = curved if degree == 2 else fit
    wid = residual_se_widening(dof)
    drift, drift_se = float(beta[2]) / ts, math.sqrt(cov[2, 2]) / ts
    # the exposures "follow the clock": r^2 of the levels' exposures on their drift terms' means
    n = np.array([f.size for _, f, _ in lv], float)
    e = np.array([x for x, _, _ in lv])
    terms = np.array([[np.mean(((t - t0) / ts) ** (k + 1)) for k in range(degree)] for _, _, t in lv])
    wsq = np.sqrt(n)[:, None]
    ols = _ols(np.column_stack([np.ones(len(lv)), terms]) * wsq, e * wsq[:, 0])
    ec = e - (n @ e) / n.sum()
    r2 = 1.0 - ols[2] / float(n @ (ec * ec)) if ols is not None and float(n @ (ec * ec)) > 0 else 1.0
    tb = terms[:, 0] * ts
    shift = float(n @ (ec * (tb - (n @ tb) / n.sum())) / (n @ (ec * ec))) if float(n @ (ec * ec)) > 0 else math.nan
    shape = "a parabola in clock time" if degree == 2 else "a line in clock time"
    return DriftFit(float(beta[1]), math.sqrt(cov[1, 1]) * wid, float(beta[0]), math.sqrt(cov[0, 0]) * wid, drift,
                    drift_se * wid, float(p), bool(p < DRIFT_P), float(min(max(r2, 0.0), 1.0)), shift,
                    f"{how}, x Student's t ({dof} dof: x {wid:.3g}); offset + rate x exposure + drift fitted on "
                    f"every frame, the drift {shape} ({drift:.3g} ± {drift_se * wid:.2g} DN/s at the sweep's mean "
                    f"time, F-test p {p:.2g})")
