"""Look-up tables the simulator's draws read: the inverse-CDF N(0,1) table of the fast Gaussian
path and Walker's alias tables for exact Poisson of one mean (see ``ares.sim.noise``)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np


@lru_cache(maxsize=1)
def table() -> np.ndarray:
    """The 2^16-entry inverse-CDF N(0,1) table of the fast path (built on first use, so that
    importing the simulator -- ``ares validate`` checks its parameters -- loads no scipy)."""
    from scipy.special import ndtri

    t = ndtri((np.arange(1 << 16) + 0.5) / (1 << 16))
    return (t / np.sqrt(np.mean(t**2))).astype(np.float32)


@lru_cache(maxsize=16)
def alias_table(lam: float):
    """(lo, prob, alias) of Walker's alias method for Poisson(lam) on [lo, lo + K)."""
    sd = np.sqrt(lam)
    lo = int(max(0.0, np.floor(lam - 12 * sd - 10)))
    hi = int(np.ceil(lam + 12 * sd + 20))
    from scipy import special  # (scipy.stats.poisson.pmf's own expression; scipy.stats costs 0.9 s to import)

    k_ = np.arange(lo, hi + 1).astype(float)
    p = np.exp(special.xlogy(k_, lam) - special.gammaln(k_ + 1) - lam)
    p = p / p.sum()
    k = len(p)
    scaled = p * k
    prob = np.ones(k)
    alias = np.arange(k)
    small = [i for i in range(k) if scaled[i] < 1.0]
    large = [i for i in range(k) if scaled[i] >= 1.0]
    while small and large:
        s_, l_ = small.pop(), large.pop()
        prob[s_], alias[s_] = scaled[s_], l_
        scaled[l_] += scaled[s_] - 1.0
        (small if scaled[l_] < 1.0 else large).append(l_)
    return lo, prob, alias.astype(np.int32)
