"""Dwell times of RTN pixels (``ares.analysis.lowlight.rtn``): what a frame series measures of them,
how well, and in seconds.

What a frame series measures of the dwell times (the truth a benchmark may hold it to). A trap
seen once a frame is a two-state chain on the frames: its level in frame t+1 depends on frame t
only, leaving the low (high) level with probability P_lo (P_hi) per frame, so its dwells are
geometric with mean d = 1/P frames -- what the simulator draws (``ares.sim.lowlight``), and what
the HMM's transition matrix estimates (d = 1/(1 - A_kk), the maximum-likelihood estimate, m/n
departures per frame in the level). A continuous-time telegraph (rates a = 1/tau_lo, b = 1/tau_hi)
sampled every T seconds (a correlated double sample of the source follower is such a sample) is
the same chain exactly: P(high at t+T | low at t) = a/(a+b) (1 - exp(-(a+b)T)), so
P_lo + P_hi = 1 - exp(-(a+b)T) and a = P_lo (a+b) / (P_lo + P_hi), i.e.
tau_lo = T (P_lo + P_hi) / (P_lo (-ln(1 - P_lo - P_hi))) (``continuous_dwell_s``; tau ~ T d when
P << 1; a dwell near T shows fewer, longer runs, as two switches within a frame are never seen).
Charge integrated over the exposure instead averages a switch into an intermediate level (not a
two-level chain); none of ARES's simulated or measured RTN is that. How well a series can know
d: with m departures the known-state estimate n/m has a relative SE sqrt((1 - P)/m) (its Fisher
information); the HMM, which also infers the states, is given 1/sqrt(m) (benchmarks/rtn.md: over
the simulator's RTS pixels its errors are within 2 SE for 93-98 %, within 3 SE for 98.3-99.7 %;
its mean error at 1000 frames, +0.6..+1.7 %, is n/m's own small-sample bias (1 - P)/m, a tenth of
the SE; the known-state estimate is within 10 % no more often than the HMM). A dwell within 10 % therefore
needs ~100 departures from the level (one SE): ~100 (d_lo + d_hi) frames, ``dwell_frames_needed``
per pixel -- 1000 frames of 5-20-frame dwells give SEs of 10-20 %, and "within 10 %" is then a
coin toss for any estimator.
"""

from __future__ import annotations

import math

import numpy as np


def dwell_rel_se(px) -> np.ndarray:
    """Per RTN pixel: the larger of its two dwell times' relative SEs."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.fmax(px.dwell_low_se / px.dwell_low_frames, px.dwell_high_se / px.dwell_high_frames)


def dwell_frames_needed(px, rel: float = 0.10) -> np.ndarray:
    """Per RTN pixel: the frames for both of its dwell SEs to reach ``rel`` of the dwell (the SE
    falls as 1/sqrt(frames): the departures grow with the frames)."""
    with np.errstate(invalid="ignore", over="ignore"):
        n = np.ceil(px.frames * (dwell_rel_se(px) / rel) ** 2)
    return np.where(np.isfinite(n), n, -1).astype(np.int64)


def continuous_dwell_s(dwell_low_frames, dwell_high_frames, period_s: float, se_low=None, se_high=None):
    """The continuous-time telegraph's mean dwells (s) that, sampled every ``period_s``, give these
    mean dwells in frames (the module docstring's derivation), with SEs by the delta method when the
    frame SEs are given: (tau_lo, tau_hi, se_lo, se_hi); NaN where P_lo + P_hi >= 1 (a chain that
    switches more often than not is no sampled telegraph)."""
    d = np.asarray(dwell_low_frames, np.float64), np.asarray(dwell_high_frames, np.float64)

    def taus(pl, ph):
        s = pl + ph
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = np.where((s > 0) & (s < 1), -np.log1p(-np.minimum(s, 1 - 1e-15)) / period_s, np.nan)
            return s / (pl * rate), s / (ph * rate)

    pl, ph = 1 / d[0], 1 / d[1]
    tl, th = taus(pl, ph)
    if se_low is None or se_high is None:
        return tl, th, None, None
    spl, sph = np.asarray(se_low, np.float64) * pl * pl, np.asarray(se_high, np.float64) * ph * ph  # SE of P = SE(d)/d^2
    h = 1e-6
    dl_pl, dh_pl = [(a - b) / (h * pl) for a, b in zip(taus(pl * (1 + h), ph), (tl, th))]
    dl_ph, dh_ph = [(a - b) / (h * ph) for a, b in zip(taus(pl, ph * (1 + h)), (tl, th))]
    return tl, th, np.hypot(dl_pl * spl, dl_ph * sph), np.hypot(dh_pl * spl, dh_ph * sph)


def dwell_precision(px, rel: float = 0.10) -> dict:
    """The RTN pixels' dwell-time SEs (relative, the larger of the two levels' per pixel): their
    median and 10/90 % quantiles (%), how many pixels have them within ``rel`` (``dwell_resolved``),
    and the frames the median pixel needs for it (``dwell_frames_needed``: "needs >= N frames")."""
    if not px.index.size:
        return {}
    worst = dwell_rel_se(px)
    fin = np.isfinite(worst)
    need = dwell_frames_needed(px, rel)
    q = np.quantile(worst[fin], (0.1, 0.5, 0.9)) * 100 if fin.any() else [math.nan] * 3
    return {"dwell_se_p10_pct": float(q[0]), "dwell_se_median_pct": float(q[1]), "dwell_se_p90_pct": float(q[2]),
            "dwell_resolved": int(np.sum(worst[fin] <= rel)),
            "dwell_frames_needed": int(np.median(need[need > 0])) if np.any(need > 0) else -1}
