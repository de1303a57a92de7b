"""Photon-transfer level statistics with a known answer, computed (not simulated pixel by
pixel): a pixel population whose charge is Gaussian (shot noise, optionally flattened by
brighter-fatter as in Astier 2019, and PRNU), clipped at a full-well charge. The clipped-
normal moments are exact; per-level measurement noise is the chi-square scatter of a
variance with ``n_pixels * (frames - 1)`` degrees of freedom. Every level carries its true
clipping bias, so a turnoff can be judged early or late."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ares.analysis.ptc.levels import LevelStats

_Z, _W = np.polynomial.hermite_e.hermegauss(60)
_W = _W / _W.sum()


def astier_var_e(mu_e, a00: float):
    """Shot-noise variance (e-^2) at mean charge mu_e, Astier 2019 C00 with g = 1."""
    mu_e = np.asarray(mu_e, float)
    if a00 == 0:
        return mu_e
    return np.expm1(2 * a00 * mu_e) / (2 * a00)


def clipped_moments(m, s, c):
    """Mean, variance and P(X >= c) of min(X, c) for X ~ N(m, s^2)."""
    a = (c - m) / s
    Phi, phi = stats.norm.cdf(a), stats.norm.pdf(a)
    e1 = m * Phi - s * phi + c * (1 - Phi)
    e2 = (m * m + s * s) * Phi - s * (c + m) * phi + c * c * (1 - Phi)
    return e1, np.maximum(e2 - e1 * e1, 0.0), 1 - Phi


@dataclass
class Truth:
    K: float  # DN/e-
    fw_e: float
    bias: np.ndarray  # relative variance bias from clipping per level (0 = unclipped)
    sat_e: float  # mean charge at which 0.2 % of samples clip (EMVA 4.0 Section 6.6)


def make_levels(mu_e, *, K=0.5, fw_e=20000.0, prnu=0.005, read_e=4.0, offset=100.0, n_pixels=100_000,
                frames=16, a00=0.0, adc_limited=False, dip: dict | None = None, seed=0):
    """Bright and dark ``LevelStats`` for mean charges ``mu_e`` (any order), plus the truth.
    ``dip``: {level index: relative variance change} imitates a sensor's local dip."""
    rng = np.random.default_rng(seed)
    mu_e = np.asarray(mu_e, float)
    dof = n_pixels * max(frames - 1, 1)
    bright, dark, bias = [], [], []
    rd = K * K * read_e**2 + 1 / 12
    for j, mu in enumerate(mu_e):
        m = mu * (1 + prnu * _Z)  # pixel means
        s = np.sqrt(np.maximum(astier_var_e(m, a00), 1e-12))
        e1, v1, pc = clipped_moments(m, s, fw_e)
        mean_e = float(_W @ e1)
        tvar_e = float(_W @ v1)
        tvar_free = float(_W @ s**2)
        bias.append(1 - tvar_e / tvar_free)
        if dip and j in dip:
            tvar_e *= 1 + dip[j]
        var = (K * K * tvar_e + rd) * rng.chisquare(dof) / dof
        frac = float(_W @ pc) if adc_limited else 0.0
        spatial = K * K * float(_W @ (e1 - mean_e) ** 2)
        bright.append(LevelStats(offset + K * mean_e + rng.normal(0, 0.002), var, n_pixels, frames, frac, 0.0,
                                 spatial))
        dark.append(LevelStats(offset + rng.normal(0, 0.002), rd * rng.chisquare(dof) / dof, n_pixels, frames))
    sat = _sat_e(fw_e, prnu, a00)
    return bright, dark, Truth(K, fw_e, np.array(bias), sat)


def _sat_e(fw_e, prnu, a00):
    """Mean charge at which 0.2 % of all samples are clipped."""
    lo, hi = 1.0, fw_e
    for _ in range(80):
        mu = 0.5 * (lo + hi)
        m = mu * (1 + prnu * _Z)
        s = np.sqrt(np.maximum(astier_var_e(m, a00), 1e-12))
        if float(_W @ (1 - stats.norm.cdf((fw_e - m) / s))) > 0.002:
            hi = mu
        else:
            lo = mu
    return 0.5 * (lo + hi)


def rel_se(level: LevelStats) -> float:
    return math.sqrt(2.0 / level.dof)
