"""The PTC turnoff as a change point (issue 48): which of the last levels before the
curve's first confirmed departure (``turnoff.ptc_turnoff_found``) is the last on the curve,
and which others the levels' scatter leaves plausible.

- ``locate``: two models of the window before the departure (a level beyond lies > 2 SE
  below the curve fitted under the window; or below it by up to the depth a straight
  roll-off to the departure gives it), each level's residual in SE of the measured scatter;
- ``fall_cost``: one global model over the window and up to ``FALL_LEVELS`` levels beyond
  the departure -- the curve below the change point, a parametric fall beyond it (rate and
  floor fitted), continuous where it turns -- so that every level of the fall, not just the
  next few, says where the curve ended. It narrows the window's plausible levels and may
  widen them by a later level or the departure itself.
- ``rolloff_evidence``: where no departure is confirmed, whether the top levels fit a
  turnover (a kink) significantly better than one smooth curve through all levels -- then
  "saturation not reached" (a lower limit) is not claimed (``sanity``).

The achievable limit (an oracle that knows the generating model but the turnoff) and the
rates reached are in ``benchmarks/ptc_corpus.md``. Pure numpy: no I/O.
"""

from __future__ import annotations

import math

import numpy as np

PLAUSIBLE = 3.0  # a turnoff whose cost (-2 log likelihood) is within this of the best one's is plausible (ratio 0.22)


def _phi_cdf(u: float) -> float:
    return 0.5 * (1.0 + math.erf(u / math.sqrt(2.0)))


FALL_LEVELS = 32  # the global change point uses up to this many levels beyond the departure
FALL_PLAUSIBLE = 10.0  # the fall model excludes a change point only beyond this cost over its best (ratio e^-5)
FALL_ADD = 3.0  # ... and a later one within this of its best stays plausible whatever the window's models say
FALL_CAP = 9.0  # ... each costing at most 3 SE squared (an upturn, a second hump, a wild row)
_FALL_R = np.concatenate([[0.0], np.geomspace(0.1, 1e4, 40)])  # fall per relative signal
_FALL_F = np.array([0.0, 0.01, 0.03, 0.1, 0.2, 0.3, 0.5])  # the floor it falls to (x the turnoff's)
# where between the last level on the curve and the next it turns: up to just before the
# next, so that a level barely past the turn (as good as on the curve) never excludes the
# level before it
_FALL_U = np.array([0.0, 0.25, 0.5, 0.75, 0.9, 0.99])
# the prior of the marginal cost (``fall_cost(marginal=True)``): the turn's place uniform between
# the levels (each grid point weighted by its share of the interval, as the window's model takes
# the depth uniform), the rate uniform over its (logarithmic) grid
_FALL_W = (np.diff(np.concatenate([[0.0], (_FALL_U[1:] + _FALL_U[:-1]) / 2, [1.0]]))[None, :]
           / _FALL_R.size)


def fall_cost(z, wild, xs, vb, sb, curve_at, marginal: bool = False):
    """-2 log likelihood (up to a constant) of each change point t (-1 .. m, as in
    ``locate``, and m: the departure itself on the curve) under one global model: the levels up to t on the curve fitted below the
    window (residuals ``z`` in SE), every level after it -- the window's and up to
    ``FALL_LEVELS`` beyond (variances ``vb``, SEs ``sb``, signals ``xs[1:]``; ``xs[0]``
    is the level before the window) -- on a fall continuous with the curve where it
    turns: v = P(xc) max(1 - r (x - xc) / xc, f), xc between level t and the next, the
    rate r and the floor f fitted (a profile over grids), each level beyond costing at
    most ``FALL_CAP``. Unlike the window's two models it uses the shape of the whole fall,
    as an oracle that knew the fall's parameters would (benchmarks/ptc_corpus.md).

    With ``marginal``: (that cost, the cost with the turn's place and the rate averaged over
    their priors -- uniform between the levels, uniform over the rate's logarithmic grid --
    not profiled; the floor still profiled). The profile lets the first level beyond the
    turn sit on the curve at no cost (the turn just before it, any rate), so that a level
    before the true last one is never told from it by the first level past it; averaged, a
    turn that fits only at the end of its interval with a finely chosen rate pays for it
    (the Occam factor of a Bayesian evidence)."""
    z = np.asarray(z, float)
    m = z.size - 1
    on = np.where(wild, 0.0, z * z)
    c_on = np.concatenate([[0.0], np.cumsum(on)])
    vb, sb = np.asarray(vb, float), np.maximum(np.asarray(sb, float), 1e-300)
    xb = np.asarray(xs[1:1 + vb.size], float)
    keep = np.ones(xb.size, bool)
    keep[: wild.size] = ~np.asarray(wild, bool)
    cost = np.full(m + 2, np.inf)
    marg = cost.copy()
    for t in range(-1, min(m + 1, xb.size - 1)):
        j0 = t + 1  # first level beyond (position in xb)
        x0 = float(xs[t + 1])
        xc = x0 + _FALL_U * (float(xb[j0]) - x0)  # (nu,)
        pc = curve_at(xc)
        if not np.all(pc > 0):
            continue
        xj, vj, sj = xb[j0:][keep[j0:]], vb[j0:][keep[j0:]], sb[j0:][keep[j0:]]
        d = np.maximum(xj[None, :] - xc[:, None], 0.0) / xc[:, None]  # (nu, nb)
        g = np.maximum(1.0 - _FALL_R[:, None, None] * d[None], _FALL_F[:, None, None, None])  # (nf, nr, nu, nb)
        r2 = np.minimum(((vj - g * pc[None, None, :, None]) / sj) ** 2, FALL_CAP).sum(-1)
        prof = r2.min(axis=0)  # (nr, nu): the floor profiled out
        b = float(prof.min())
        cost[t + 1] = c_on[t + 1] + b
        marg[t + 1] = c_on[t + 1] + b - 2.0 * math.log(float(np.sum(_FALL_W * np.exp(-(prof - b) / 2))))
    return (cost, marg) if marginal else cost


def locate(z, wild, xs, fall=None, plausible: float = PLAUSIBLE,
           fall_plausible: float = FALL_PLAUSIBLE) -> tuple[int, int, int]:
    """(the level -- position in the window -- most likely the last on the curve, and the
    first and last plausible ones; -1: the level before the window). A change-point choice
    on ``z``, each level's residual from the curve fitted below the window in SE (the last
    is the departure), at signals ``xs`` (one more at the front: the level before the
    window). The turnoff is level t when the levels up to t follow the curve (z ~ N(0, 1))
    and those after it have rolled off: the curve turns somewhere between level t and the
    next, and falls to the departure's depth, so a level beyond lies below the curve by an
    amount uniform between 0 and the depth a straight roll-off from level t would give it,
    plus its noise. A level barely below the curve just before a deep departure is then
    unlikely to be beyond (a clip), one on a gentle roll-off is doubtful; every t within
    ``PLAUSIBLE`` of the best is plausible (and under the one-sided model below, which
    picks the level). Rows above the curve (``wild``) belong to neither. ``plausible``,
    ``fall_plausible``: the thresholds (``turnoff`` tightens both where the levels' measured
    scatter is <= 1 %)."""
    z = np.asarray(z, float)
    wild = np.asarray(wild, bool)
    xs = np.asarray(xs, float)
    m = z.size - 1
    on = np.where(wild, 0.0, z * z + math.log(2 * math.pi))
    cost = np.full(m + 1, np.inf)
    for t in range(-1, m):
        if t >= 0 and wild[t]:
            continue  # a wild row is no turnoff
        c = float(np.sum(on[:t + 1]))
        x0, span = xs[t + 1], xs[-1] - xs[t + 1]
        for j in range(t + 1, m):
            if wild[j]:
                continue
            depth = min(float(z[-1]), 0.0) * (xs[j + 1] - x0) / span if span > 0 else 0.0
            if depth > -0.5:  # no room to fall: beyond or not, it sits on the curve
                c += on[j]
                continue
            p = (_phi_cdf(z[j] - depth) - _phi_cdf(z[j])) / -depth
            c += -2.0 * math.log(max(p, 1e-300))
        cost[t + 1] = c
    # the same choice where a level beyond lies > 2 SE below the curve (cost OFF_PENALTY
    # each, plus z^2 above it) whatever the departure's depth: the most likely turnoff, and
    # a turnoff is plausible only where both models allow it
    one = np.where(wild, 0.0, OFF_PENALTY + np.maximum(z, 0.0) ** 2)
    c_on = np.concatenate([[0.0], np.cumsum(np.where(wild, 0.0, z * z)[:m])])
    c_off = np.concatenate([[0.0], np.cumsum(one[:m][::-1])])[::-1]
    cost1 = np.where(np.isfinite(cost), c_on + c_off, np.inf)
    best = int(np.argmin(cost1))
    ok = (cost1 <= cost1[best] + plausible) & (cost <= np.min(cost) + plausible)
    pick = np.arange(m + 1) == best
    beyond_departure = False
    if fall is not None and np.isfinite(fall).any():
        fall_ok = fall <= np.min(fall) + fall_plausible
        # the fall model narrows the window's plausible levels; a later level it finds nearly
        # as likely as its best (the window's fit below took a bend for a fall) stays
        # plausible, and it alone can judge the departure itself on the curve
        ok = (ok & fall_ok[:m + 1]) | ((fall <= np.min(fall) + FALL_ADD)[:m + 1] & (np.arange(m + 1) > best))
        beyond_departure = bool(fall_ok[m + 1])
    plaus = np.flatnonzero(ok | pick)
    if beyond_departure:
        return best - 1, int(plaus[0]) - 1, m
    return best - 1, int(plaus[0]) - 1, int(plaus[-1]) - 1


OFF_PENALTY = 4.0  # a level is called beyond the turnoff (one-sided model) only when > 2 SE below the curve


# a turnover above the last level is plausible where a kink gains more than this chi-square
# (2 SE, as OFF_PENALTY) over one smooth curve ...
ROLL_EVIDENCE = 4.0
ROLL_DEPTH = 0.02  # ... and takes the top level at least 2 % below the smooth curve
ROLL_DEGREE = 2  # the smooth curve: a parabola (or a cubic, whichever fits better)


def rolloff_evidence(x, v, e, first: int, between: tuple = (0.0,)) -> tuple[float, int, int]:
    """Is the top of a curve with no confirmed departure still on it? (The lower limit
    "saturation not reached" is a claim, as safe as an "ok" must be: issue 48.) One smooth
    curve through every level -- a weighted parabola, or a cubic where it fits better (the
    brighter-fatter bend and its next term) -- against the parabola with a kink at level t
    (the slope dropping there, or falling from there on; one-sided), for every t from
    ``first`` to the second-last level, on the errors ``e`` (the measured scatter), scaled
    up by the kinked fit's own excess scatter. Returns (the largest chi-square gain of a
    kink whose depth at the top level is at least ``ROLL_DEPTH`` of the curve there, the
    first and last t within ``PLAUSIBLE`` of it); (0, -1, -1) when none is. ``between``:
    where between level t and the next the kink may lie (0: at level t; a sparse curve's
    turn lies between its levels, ``turnoff._gentle_lo``). On curves truly
    below their turnoff (0-10 % noise, 8-400 levels) 97 % keep their lower limit
    (``benchmarks/ptc_corpus.md``)."""
    x = np.asarray(x, float)
    v = np.asarray(v, float)
    n = x.size
    if n < ROLL_DEGREE + 4 or first >= n - 1:
        return 0.0, -1, -1
    x = x / (float(np.max(np.abs(x))) or 1.0)
    sw = 1.0 / np.maximum(np.asarray(e, float), 1e-300)
    a0 = np.stack([x**k for k in range(ROLL_DEGREE + 1)], 1)

    def fit(a):
        aw = a * sw[:, None]
        c = np.linalg.lstsq(aw, v * sw, rcond=None)[0]
        r = v * sw - aw @ c
        return c, float(r @ r)

    _, chi0 = fit(a0)
    # (a smooth bend of higher order -- the brighter-fatter curve's next term -- explains a
    # deficit at the top as well: the kink must beat it too, with as many parameters)
    chi0 = min(chi0, fit(np.column_stack([a0, x ** (ROLL_DEGREE + 1)]))[1])
    gain = np.zeros(n)
    for t in range(max(first, 2), n - 1):
        # the slope dropping at the kink (a roll-off) or falling from it on (a bend beginning
        # there); the kink at level t or a fraction ``between`` of the way to the next (t is
        # then still the last level on the curve)
        for p, u in ((p_, u_) for p_ in (1, 2) for u_ in between):
            h = np.maximum(x - (x[t] + u * (x[t + 1] - x[t])), 0.0) ** p
            c, chi = fit(np.column_stack([a0, h]))
            top = float(a0[-1] @ c[:-1])
            if c[-1] < 0 and top > 0 and -c[-1] * h[-1] >= ROLL_DEPTH * top:
                gain[t] = max(gain[t], (chi0 - chi) / max(chi / max(n - a0.shape[1] - 1, 1), 1.0))
    best = int(np.argmax(gain))
    if gain[best] <= 0:
        return 0.0, -1, -1
    near = np.flatnonzero(gain >= gain[best] - PLAUSIBLE)
    return float(gain[best]), int(near[0]), int(near[-1])
