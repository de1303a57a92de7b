"""The PTC turnoff and the errors its decisions are taken on (issue 48).

- ``decision_errors``: the per-level variance errors every photon-transfer decision uses
  (the turnoff, the gain model's residual tests): from the pixel and frame counts where
  known (with the signal's own error through the slope, the effective variance), always
  checked against the scatter the levels actually show about a local quadratic
  (``stats.scatter``); where the two disagree the measured scatter wins, and the note says
  so. Without counts the measured scatter is the error; with neither (too few levels) no
  error is claimed and the errorless rule below decides.
- ``ptc_turnoff``: the curve followed from below to its first significant departure,
  confirmed by the levels after it (see its docstring). Linear in the number of levels:
  every prefix fit comes from running sums.
- ``lsst_pivot``: the errorless rule, LSST cp_pipe's PTC solver (``PhotonTransferCurveSolveTask``,
  ``_getInitialGoodPoints``, used when ``doLegacyTurnoffSelection``): in signal order, the
  curve ends before the first run of at least two consecutive variance decreases; its
  ``ptcTurnoff`` is the highest mean kept.
- ``ramp_turnoff`` (a linearity ramp without variances) lives in ``ptc.ramp``.

Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.scatter import Scatter, local_residuals, measured_scatter
from ares.analysis.stats.median import fast_median
from ares.analysis.ptc.changepoint import (FALL_LEVELS, FALL_PLAUSIBLE, PLAUSIBLE, ROLL_EVIDENCE, fall_cost, locate,
                                            rolloff_evidence)


# ----------------------------------------------------------------- decision errors

@dataclass(frozen=True)
class DecisionErrors:
    """Per-level variance errors (DN^2, in the input's order) and how they were found."""

    se: np.ndarray  # NaN everywhere when ``source == "none"``
    source: str  # "counts" | "measured" | "none"
    scatter: Scatter
    note: str


def _local_median(a: np.ndarray, half: int = 2) -> np.ndarray:
    """Median of each value with its ``half`` neighbours each side (clamped at the ends;
    no NaN functions: they import numpy.ma, ~0.1 s)."""
    n = a.size
    if n == 0:
        return a
    idx = np.clip(np.arange(n)[:, None] + np.arange(-half, half + 1)[None, :], 0, n - 1)
    return fast_median(a[idx], axis=1)


def _smooth_scale(S, V, use, offset) -> np.ndarray:
    """Per level, (smooth + offset) / (measured + offset): the variance a level's error is
    proportional to, taken from the leave-one-out local quadratic of its neighbours instead
    of its own noisy value. An error proportional to the measured value weights the levels
    that fell low more than those that rose (a bias of many SEs over hundreds of levels);
    1 where no smooth value exists, and within [0.5, 2]."""
    n = S.size
    f = np.ones(n)
    idx = np.flatnonzero(use)
    if idx.size < 6:
        return f
    o = idx[np.argsort(S[idx], kind="stable")]
    r, _ = local_residuals(S[o], V[o])
    num, den = V[o] - r + offset[o], V[o] + offset[o]
    ok = (num > 0) & (den > 0)
    f[o[ok]] = np.clip(num[ok] / den[ok], 0.5, 2.0)
    return f


def decision_errors(S, V, Vse, signal_se=None, counts_known: bool = True, curve=None,
                    offset=None) -> DecisionErrors:
    """Errors for the decisions on levels ``S``, ``V`` (DN, DN^2) whose count-based variance
    errors are ``Vse``. ``signal_se`` (DN): each level's signal error not shared by all
    levels; estimated from few frames it is itself noisy, so each level takes the median of
    its own and its 4 neighbours' (in signal order). ``curve``: the levels (boolean mask)
    on which the scatter is measured -- those on the curve, not beyond it. ``offset``
    (DN^2): the part of each level's raw variance not in ``V`` (the dark variance), so that
    the errors scale with the raw variance's smooth value (``_smooth_scale``)."""
    S = np.asarray(S, float)
    V = np.asarray(V, float)
    n = S.size
    use = np.isfinite(S) & np.isfinite(V) & np.isfinite(np.asarray(Vse, float)) & (S > 0)
    if curve is not None:
        use &= np.asarray(curve, bool)
    off = np.zeros(n) if offset is None else np.nan_to_num(np.asarray(offset, float))
    fsm = _smooth_scale(S, V, use, off)
    Vse = np.asarray(Vse, float) * fsm
    # the slope that turns a signal error into a variance error: median V/S of the usable levels
    k0 = float(fast_median(V[use] / S[use])) if use.any() else math.nan
    e = Vse.copy()
    sse_note = ""
    if signal_se is not None and math.isfinite(k0) and k0 > 0:
        sse = np.asarray(signal_se, float)
        if sse.size == n and np.isfinite(sse).any():
            o = np.argsort(np.where(np.isfinite(S), S, np.inf), kind="stable")
            sm = np.empty(n)
            sm[o] = _local_median(np.where(np.isfinite(sse[o]), sse[o], 0.0))  # (unknown: 0)
            e = np.hypot(Vse, k0 * sm)
            sse_note = " with each level's signal error (local median of 5) through the slope"
    if not counts_known:
        e = np.maximum(np.abs(V + off) * fsm, 1e-300)  # a relative scale until the scatter says how large
    idx = np.flatnonzero(use)
    sc = measured_scatter(S[idx], V[idx], e[idx])
    # an error is never below rounding: levels on a smooth curve to 1e-9 are exact, and
    # their decisions fall to the relative floors (the turnoff's 2 %)
    e = np.maximum(e, 1e-9 * np.abs(V) + 1e-300)
    if sc.available:
        sc = Scatter(max(sc.ratio, 1e-9), sc.ratio_se, sc.n, sc.disagree, sc.note)
    if not counts_known:
        if not sc.available:
            return DecisionErrors(np.full(n, math.nan), "none", sc,
                                  f"no pixel or frame counts and {sc.n} levels on the curve: too few to measure the "
                                  "scatter, so no error is claimed and the errorless rules decide (LSST cp_pipe "
                                  "turnoff; unweighted line)")
        return DecisionErrors(e * sc.ratio, "measured", sc,
                              f"no pixel or frame counts: each level's variance error is the measured relative "
                              f"scatter about a local quadratic, {sc.ratio:.3g} ± {sc.ratio_se:.2g} x the variance "
                              f"(MAD of {sc.n} levels)")
    if sc.available and sc.disagree:
        return DecisionErrors(e * sc.ratio, "measured", sc,
                              f"the levels scatter {sc.ratio:.3g} ± {sc.ratio_se:.2g} times the errors from their "
                              f"pixel and frame counts{sse_note} (MAD about a local quadratic, {sc.n} levels): the "
                              "measured scatter is used for the turnoff and the model choice")
    why = (f"consistent with the measured scatter ({sc.ratio:.3g} ± {sc.ratio_se:.2g} x, {sc.n} levels)"
           if sc.available else sc.note)
    return DecisionErrors(e, "counts", sc, f"variance errors from the pixel and frame counts{sse_note}: {why}")


# ------------------------------------------------------------------- the turnoff

def _cum0(a: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(a)])


def ptc_turnoff(signal, var, var_se, **kw) -> int:
    """Number of levels, from the bottom of the signal-sorted input, that lie on the PTC
    (``ptc_turnoff_found``)."""
    return ptc_turnoff_found(signal, var, var_se, **kw).n_on


def ptc_turnoff_found(signal, var, var_se, nsigma: float = 4.0, min_levels: int = 4, confirm: int = 3,
                      rel_floor: float = 0.02, collapse: float = 0.7, lookback: int = 5,
                      flat_floor: float = 0.10, window: float = 0.15) -> "TurnoffFound":
    """Levels on the PTC from the bottom of the signal-sorted input, the level where the
    departure was seen, and the levels that may be the last on the curve given the
    scatter -- the turnoff's identification (``TurnoffFound``).

    The curve is followed from below and stops at the first significant departure: level
    ``i`` departs when its variance is below the curve fitted to the levels under it (a
    line, or a parabola when its curvature is significant: brighter-fatter flattening) by
    more than ``nsigma`` standard errors (its own, inflated by the fit's excess scatter,
    combined with the prediction's), or below the highest variance under it by more than
    ``nsigma`` SE -- and by more than ``flat_floor`` (10 %) below the curve or ``rel_floor``
    (2 %) below that maximum. A departure
    counts when the next level departs too (two in a row, as LSST cp_pipe's two consecutive
    decreases) or at least half of the next ``confirm`` levels do (or it is the last
    level). Among the first quarter of the levels a departure counts only where the
    variance truly collapses (below ``collapse`` of the highest under it): a curve does not
    end at its first levels on a few standard errors. Which of the last levels before the
    departure is the last on the curve, and which others the scatter leaves plausible, is a
    change-point choice (``changepoint.locate``). Whatever lies beyond the first
    departure -- an outlier row, an upturn, a second hump -- cannot move it. ``var_se``
    must describe the levels' scatter (``decision_errors``). Inputs sorted by signal, free
    of clipped or empty levels. Linear in the levels: the prefix fits come from running
    sums (of residuals from a reference line, so that no sum cancels)."""
    s = np.asarray(signal, float)
    v = np.asarray(var, float)
    e = np.maximum(np.asarray(var_se, float), 1e-300)
    n = s.size
    if n <= min_levels:
        return TurnoffFound(n, n, n - 1, n - 1)
    smax = float(np.max(np.abs(s))) or 1.0
    x = s / smax
    half = max(n // 2, 2)
    ref = np.polyfit(x[:half], v[:half], 1) if np.ptp(x[:half]) > 0 else np.array([0.0, float(np.mean(v[:half]))])
    u = v - np.polyval(ref, x)
    w = 1.0 / (e * e)
    P = [_cum0(w * x**k) for k in range(5)]
    B = [_cum0(w * x**k * u) for k in range(3)]
    C = _cum0(w * u * u)
    i = np.arange(min_levels, n)  # candidate level i, fitted on levels 0 .. i-1
    M3 = np.stack([np.stack([P[a + b][i] for b in range(3)], -1) for a in range(3)], -2)
    b3 = np.stack([B[a][i] for a in range(3)], -1)
    inv3 = np.linalg.pinv(M3)
    c3 = np.einsum("mij,mj->mi", inv3, b3)
    inv2 = np.linalg.pinv(M3[:, :2, :2])
    c2 = np.einsum("mij,mj->mi", inv2, b3[:, :2])

    def chi2(c, k, m):
        q = C[i] - 2 * np.einsum("mi,mi->m", c, b3[:, :k]) + np.einsum("mi,mij,mj->m", c, m, c)
        return np.maximum(q, 0.0) / np.maximum(i - k, 1)

    x2 = chi2(c2, 2, M3[:, :2, :2])
    x3 = chi2(c3, 3, M3)
    curved = (i >= 5) & (np.abs(c3[:, 2]) > 3.0 * np.sqrt(np.maximum(inv3[:, 2, 2], 0) * np.maximum(x3, 1.0)))
    coef = np.where(curved[:, None], c3, np.concatenate([c2, np.zeros((i.size, 1))], 1))
    cov = np.where(curved[:, None, None], inv3, np.pad(inv2, ((0, 0), (0, 1), (0, 1))))
    chi = np.where(curved, x3, x2)
    scale = np.sqrt(np.maximum(chi, 1.0))
    # a row above the curve fitted below it by > nsigma SE (a wild row before the turnover: an
    # outlier of heavy-tailed scatter) is no top that the levels after it fall below (issue 48)
    a0 = np.stack([np.ones(i.size), x[i], x[i] ** 2], -1)
    s0 = np.sqrt(np.maximum(np.einsum("mi,mij,mj->m", a0, cov, a0), 0.0)) * scale
    p0 = np.einsum("mi,mi->m", a0, coef) + np.polyval(ref, x[i])
    vt = v.copy()
    vt[i[v[i] - p0 > nsigma * np.hypot(e[i] * scale, s0)]] = -np.inf
    def top(w):  # the highest variance under each level i, and its error
        runmax = np.maximum.accumulate(w)
        idx = np.maximum.accumulate(np.where(np.concatenate([[True], w[1:] >= runmax[:-1]]), np.arange(n), 0))
        return runmax[i - 1], e[idx[i - 1]]

    (vtop, etop), (wtop, wetop) = top(vt), top(v)
    early = i < max(min_levels + 1, n // 4)
    dep = np.zeros((i.size, confirm + 1), bool)
    valid = np.zeros_like(dep)
    for k in range(confirm + 1):
        j = i + k
        ok = j < n
        jj = np.minimum(j, n - 1)
        a = np.stack([np.ones(i.size), x[jj], x[jj] ** 2], -1)
        pred = np.einsum("mi,mi->m", a, coef) + np.polyval(ref, x[jj])
        pse = np.sqrt(np.maximum(np.einsum("mi,mij,mj->m", a, cov, a), 0.0)) * scale
        # a flattening alone (the variance still rising, below the curve) ends the curve only
        # beyond ``flat_floor`` (10 %): over a few levels a brighter-fatter bend the line
        # fitted below cannot follow looks the same up to several percent (issue 48)
        below_curve = v[jj] - pred < -np.maximum(nsigma * np.hypot(e[jj] * scale, pse), flat_floor * np.abs(pred))
        below_top = v[jj] < vtop - np.maximum(nsigma * scale * np.hypot(e[jj], etop), rel_floor * vtop)
        # ... or below a wild row's top where the level itself lies > 1 SE below the curve
        below_top |= (v[jj] < wtop - np.maximum(nsigma * scale * np.hypot(e[jj], wetop), rel_floor * wtop)) & (
            v[jj] - pred < -1.0 * np.hypot(e[jj] * scale, pse))
        d = below_curve | below_top
        d &= ~early | (v[jj] < collapse * vtop)
        if k:  # a repeated row (the same signal) is the same level, not a confirmation
            ok &= x[jj] > x[i]
        dep[:, k] = d & ok
        if k == 0:  # a fall deeper than any flattening (1.5 x the floor): a turnover if confirmed
            deep = d & (v[jj] - pred < -1.5 * flat_floor * np.abs(pred))
            # (each level's residual from the curve below it, for a run of levels jointly below it)
            zz0 = (v[jj] - pred) / np.maximum(np.hypot(e[jj] * scale, pse), 1e-300)
            low0 = (v[jj] - pred < -flat_floor * np.abs(pred)) & (zz0 < -RUN_SE) & ~early
        valid[:, k] = ok
    n_after = valid[:, 1:].sum(1)
    hits = dep[:, 1:].sum(1)
    stop = dep[:, 0] & ((n_after == 0) | dep[:, 1] | (2 * hits >= n_after))
    first = np.flatnonzero(stop)
    fell = np.flatnonzero(dep[:, 0] & (v[i] < collapse * vtop))
    if not first.size and fell.size:  # the variance collapsed and came back (a second hump, 2 frames): the
        k = int(i[fell[0]])  # curve is fitted no further; it may have ended anywhere past its first quarter
        return TurnoffFound(k, k, max(min_levels, n // 4) - 1, n - 1)  # (a hump rising on: corpus curve 760)
    if not first.size:
        # no departure confirmed: "saturation not reached" is a lower limit only when the top
        # levels are consistent with one smooth curve; where a kink fits them significantly
        # better (a gentle roll-off the fits below took for a bend) the turnoff may lie lower
        ev, t_lo, t_hi = rolloff_evidence(x, v, e, max(min_levels, n // 4))
        if ev > ROLL_EVIDENCE:
            return TurnoffFound(n, n, t_lo, t_hi)
        return TurnoffFound(n, n, n - 1, n - 1)
    stop_i = int(i[first[0]])
    # an earlier departure the next levels did not confirm (a dip, or the first fall of a
    # curve that climbs a second hump): the turnoff may lie there too (its ambiguity)
    # ... or a run of consecutive levels each > ``flat_floor`` (10 %) and > ``RUN_SE`` below the
    # curve fitted under it, jointly > ``RUN_CHI2`` -- none alone a departure at 5-10 % scatter:
    # the shallow first fall of a curve that climbs a second hump near the curve's extension
    deep = deep | _run_starts(low0, zz0)
    unconf = np.flatnonzero(deep & ~stop & (i < stop_i))
    lo = max(min_levels, stop_i - lookback)
    # (a roll-off seen at the departure began within ``window`` (15 %) of its signal: on a
    # sparse curve the fit below extrapolates no further)
    lo = max(lo, int(np.searchsorted(x, (1 - window) * x[stop_i])))
    if stop_i - lo < 1:
        return TurnoffFound(stop_i, stop_i, _gentle_lo(x, v, e, stop_i - 1, max(min_levels, n // 4),
                            max(min(stop_i - 1, int(i[unconf[0]]) - 1 if unconf.size else n), 0)), stop_i - 1)
    # the departure is seen where it exceeds nsigma; a gradual roll-off began up to
    # ``lookback`` levels earlier. Which of the levels lo-1 .. stop_i-1 is the last on the
    # curve is a change-point choice (``changepoint.locate``) on their residuals from the curve fitted
    # below the window -- in SE of the measured scatter and of the prediction, with a model
    # floor (below) -- not the highest (noisy) variance
    q = lo - min_levels
    k = np.arange(lo, stop_i + 1)
    A = np.stack([np.ones(k.size), x[k], x[k] ** 2], -1)
    pred = A @ coef[q] + np.polyval(ref, x[k])
    pse = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", A, cov[q], A), 0.0)) * scale[q]
    # the model floor: twice the relative misfit of the fit at its last levels below the
    # window (a bend it does not follow), at most flat_floor / nsigma; 0 on a curve it follows
    kb = np.arange(max(lo - 5, 0), lo)
    Ab = np.stack([np.ones(kb.size), x[kb], x[kb] ** 2], -1)
    fb = Ab @ coef[q] + np.polyval(ref, x[kb])
    mis = float(np.sqrt(np.mean(((v[kb] - fb) / np.where(fb != 0, fb, 1.0)) ** 2))) if kb.size else 0.0
    sig = np.hypot(np.hypot(e[k] * scale[q], pse), min(2 * mis, flat_floor / nsigma) * np.abs(pred))
    # (a wild row above the curve -- > 10 % and nsigma above the fit below the window -- is on neither side)
    wild = v[k] - pred > np.maximum(nsigma * np.hypot(e[k] * scale[q], pse), flat_floor * np.abs(pred))
    # the global change point: the levels beyond the window too (up to ``FALL_LEVELS`` past
    # the departure), on a fall continuous at the turnoff (``_fall_cost``)
    kf = np.arange(stop_i + 1, min(n, stop_i + 1 + FALL_LEVELS))
    Af = np.stack([np.ones(kf.size), x[kf], x[kf] ** 2], -1)
    pf = Af @ coef[q] + np.polyval(ref, x[kf])
    pfse = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", Af, cov[q], Af), 0.0)) * scale[q]
    sig_f = np.hypot(np.hypot(e[kf] * scale[q], pfse), min(2 * mis, flat_floor / nsigma) * np.abs(pf))
    kk = np.concatenate([k, kf])

    def curve_at(xc):
        xc = np.asarray(xc, float)
        return coef[q][0] + coef[q][1] * xc + coef[q][2] * xc * xc + np.polyval(ref, xc)

    z = (v[k] - pred) / np.maximum(sig, 1e-300)
    fall, fall_m = fall_cost(z, wild, x[lo - 1:], v[kk], np.concatenate([sig, sig_f]), curve_at, marginal=True)
    # the levels' measured relative scatter at the window (their decision errors over their variances)
    rel = float(np.median(e[k[:-1]] / np.maximum(np.abs(v[k[:-1]]), 1e-300)))
    low = rel <= LOW_NOISE
    best, a_lo, a_hi = locate(z, wild, x[lo - 1:stop_i + 1], fall, PLAUSIBLE_LOW_NOISE if low else PLAUSIBLE,
                              FALL_LOW_NOISE if low else FALL_PLAUSIBLE)
    t = lo + best
    # the level found may itself lie just beyond the turnoff (a gentle roll-off's first
    # level, not yet below the curve): any level before it whose variance the scatter
    # cannot tell from its own (within ``PEAK_SE``) may be the peak
    j = np.arange(max(lo - 1, 0), t)
    same = (~wild[np.maximum(j - lo, 0)] | (j < lo)) & (v[j] >= v[t] - PEAK_SE * scale[q] * np.hypot(e[j], e[t]))
    tight = same.copy()
    if np.isfinite(fall).any():  # ... unless the fall beyond it says it is not (the global change point)
        same &= fall[j - lo + 1] <= np.min(fall) + FALL_PLAUSIBLE
        # where the levels scatter <= ``BEFORE_LOW_NOISE`` (their measured relative scatter,
        # times the fit's own excess scatter below the window where larger: counts that
        # claim too much precision fool the scatter check on few levels), within e^-3 of the
        # best by the fall model's marginal cost (the turn's place and the rate averaged, not
        # profiled: ``fall_cost``)
        if rel * scale[q] <= BEFORE_LOW_NOISE:
            tight &= fall_m[j - lo + 1] <= np.min(fall_m) + BEFORE_FALL
        else:
            tight = same
    else:
        tight = same
    # the turnoff's own interval (``tight``) and the wider one a charge at its level is
    # judged on (``same``: a level late within the tightened interval and K low, each within
    # its uncertainty, gave a saturation capacity 3.2 % off -- corpus seed 0 curve 1084)
    def first_of(ok) -> int:
        b = min(a_lo, int(j[ok][0]) - lo) if ok.any() else a_lo
        b += lo
        if unconf.size:  # the curve fell there and came back: the turnoff may be that fall
            b = min(b, int(i[unconf[0]]) - 1)
        return max(b, 0)

    out = [first_of(tight), first_of(same)]
    if stop_i - lo < lookback:  # (a window cut short by its 15 %: a gentle roll-off may have begun below it)
        g = [_gentle_lo(x, v, e, t, max(min_levels, n // 4), out[0])]
        g.append(g[0] if out[1] == out[0] else _gentle_lo(x, v, e, t, max(min_levels, n // 4), out[1]))
        out = g
    return TurnoffFound(t + 1, stop_i, out[0], lo + a_hi, out[1])


def _run_starts(low, z) -> np.ndarray:
    """Where each run of consecutive ``low`` levels (two or more) whose ``z`` squared sum to
    at least ``RUN_CHI2`` starts (boolean, per level)."""
    out = np.zeros(low.size, bool)
    idx = np.flatnonzero(low)
    if idx.size < 2:
        return out
    breaks = np.flatnonzero(np.diff(idx) > 1) + 1
    for r in np.split(idx, breaks):
        if r.size >= 2 and float(np.sum(z[r] ** 2)) >= RUN_CHI2:
            out[r[0]] = True
    return out


def _gentle_lo(x, v, e, t: int, first: int, a_lo: int) -> int:
    """The first plausible last level on the curve, ``a_lo``, lowered where the levels up to
    the turnoff found (``t``) and the next one fit a turnover (``changepoint.rolloff_evidence``,
    kinks at and halfway between levels) significantly better than one smooth curve, with
    every plausible kink below ``a_lo``, and the next level's variance still above level
    ``t``'s: a gentle roll-off (the slope falling ~1.5 per unit of relative signal, the
    variance still rising) is taken for a brighter-fatter bend by
    the fits below and confirmed as a departure a level or more late, beyond the window
    (``window``, 15 %) on a sparse curve (issue 48; ``benchmarks/ptc_corpus.md``)."""
    m = min(t + 2, x.size)
    if m < t + 2 or v[t + 1] < v[t]:  # (the next level falls: a departure the window's models judge)
        return a_lo
    ev, t_lo, t_hi = rolloff_evidence(x[:m], v[:m], e[:m], first, between=(0.0, 0.5))
    if ev > ROLL_EVIDENCE and 0 <= t_lo <= t_hi < a_lo:
        return t_lo
    return a_lo


# where the levels' measured relative scatter at the window is <= 1 %, the window's two models
# keep a level plausible only within e^-0.5 of their best (1 in -2 log likelihood), not e^-1.5,
# and the fall model excludes one beyond e^-3, not e^-5: chosen on corpus seed 0, checked on
# the held-out seed 1 -- no new wrong "ok" on either; at higher scatter every such tightening
# cost wrong "ok"s on both seeds (benchmarks/ptc_corpus.md)
LOW_NOISE = 0.01
PLAUSIBLE_LOW_NOISE = 1.0
FALL_LOW_NOISE = 6.0
# a run of levels each > 2 SE and > 10 % below the curve fitted under it, jointly > 5 SE (25 in
# chi-square), is a fall the next levels did not confirm (the turnoff may lie there): chosen on
# corpus seed 0 (wrong "ok" turnoffs 15 -> 13, none lost), checked on seed 1 (18 -> 17)
RUN_SE = 2.0
RUN_CHI2 = 25.0
PEAK_SE = 0.5  # a level before it within 0.5 SE of its variance may be the peak (a roll-off's first level beyond it)
# ... allowed by the fall model within e^-5 (``FALL_PLAUSIBLE``), or within e^-3 of its marginal
# cost where the levels scatter <= 7 % (the turnoff's own interval; its charge keeps the wider one)
# (4 % with the profile; 7 % with the marginal cost: the largest on corpus seed 0 with no wrong
# "ok" added -- 8 % added two -- checked on the held-out seeds 1, 2 and 3: none added)
BEFORE_LOW_NOISE = 0.07
BEFORE_FALL = 6.0


@dataclass(frozen=True)
class TurnoffFound:
    """``ptc_turnoff_found``'s answer (indices into the signal-sorted input)."""

    n_on: int  # levels on the curve: the turnoff is level n_on - 1
    seen: int  # the level where the departure was seen (n: none)
    amb_lo: int  # the levels that may be the last on the curve, given the scatter: amb_lo .. amb_hi
    amb_hi: int  # (no departure seen: n - 1, or below it where the top levels fit a turnover, ``rolloff_evidence``)
    amb_lo_wide: int = -1  # amb_lo before the low-scatter tightening (the charge at the turnoff is judged on it; -1: amb_lo)

    @property
    def lo_wide(self) -> int:
        return self.amb_lo_wide if self.amb_lo_wide >= 0 else self.amb_lo

    def __iter__(self):  # (n_on, seen), as before
        return iter((self.n_on, self.seen))


def lsst_pivot(var, min_var: float = 0.0, consecutive: int = 2) -> int:
    """LSST cp_pipe's errorless PTC cut (``_getInitialGoodPoints``): in signal order, the
    number of levels kept -- up to the start of the first run of ``consecutive`` (2)
    variance decreases at a variance above ``min_var``; all levels when there is none."""
    v = np.asarray(var, float)
    n = v.size
    drop = np.diff(v) < 0
    drop &= v[:-1] > min_var
    run = 0
    for j, d in enumerate(drop):
        run = run + 1 if d else 0
        if run >= consecutive:
            return j - consecutive + 2  # keep the level the first decrease starts from
    return n
