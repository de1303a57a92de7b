"""Temporal random draws: per-frame streams, fast Gaussian deviates, shot noise.

Every frame ``f`` of a sensor with seed ``s`` draws from its own stream
``SeedSequence(s, spawn_key=(1, f))``, so frame f is the same whatever was rendered
before it (state-carrying processes — RTS, lag — excepted).

Two generators of N(0,1) deviates:

* ``exact``: numpy's ziggurat (``Generator.standard_normal``).
* ``fast``: a 2**16-entry inverse-CDF table indexed by random 16-bit words
  (about 4x faster). The table holds the normal quantiles at (i + 0.5) / 2**16, rescaled
  to unit variance, so mean and variance are exact; tails are cut at 4.3 sigma and the
  kurtosis is 2.99 instead of 3. Measured in ``benchmarks/sim.md``.

Shot noise (Poisson of mean ``m`` e-): exact, or the Gaussian
``m + sqrt(m) * z`` (same mean and variance; skewness 0 instead of ``1/sqrt(m)``). The
``auto`` mode uses the Gaussian for a pixel only where the pixel's total temporal
distribution (Poisson + Gaussian read/chain/quantization noise of variance ``s2`` in e-^2)
would have skewness ``m / (m + s2)**1.5`` below ``AUTO_SKEW_TOLERANCE`` — i.e. where
no measurement could tell the difference — and exact Poisson elsewhere.

Exact Poisson of one mean for many pixels (a flat) uses Walker's alias method over the
pmf on ``m +- 12 sqrt(m)`` (mass outside < 1e-30; probabilities in float64): two table
look-ups per pixel, 3-5x faster than ``Generator.poisson``. Per-pixel means (maps):
counting unit-rate Poisson-process arrivals in [0, mean] (float64 exponential
spacings) for means up to ``INVERSION_MAX_MEAN`` -- a dark frame's fraction of an
e- -- and ``Generator.poisson`` for the rest.
"""

from __future__ import annotations

import numpy as np

from ares.sim.fused import words16
from ares.sim.tables import alias_table, table

AUTO_SKEW_TOLERANCE = 0.05
SHOT_MODES = ("auto", "exact", "gaussian")
INVERSION_MAX_MEAN = 2.0


def frame_rng(seed: int, frame: int) -> np.random.Generator:
    """The random stream of one frame."""
    return np.random.Generator(np.random.SFC64(np.random.SeedSequence(seed, spawn_key=(1, int(frame)))))



def normal(rng: np.random.Generator, shape, fast: bool) -> np.ndarray:
    """float32 N(0,1) deviates of the given shape."""
    if fast:
        return np.take(table(), words16(rng, shape))
    return rng.standard_normal(size=shape, dtype=np.float32)


def shot_skewness(mean_e, gauss_var_e2):
    """Skewness of Poisson(mean) + N(0, gauss_var): mean / (mean + var)**1.5."""
    m = np.asarray(mean_e, np.float64)
    tot = m + gauss_var_e2
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(tot > 0, m / np.maximum(tot, 1e-300) ** 1.5, 0.0)


def exact_mask(mean_e, gauss_var_e2, mode: str):
    """Where shot noise must be drawn exactly: bool (scalar) or bool map."""
    if mode == "exact":
        return True
    if mode == "gaussian":
        return False
    if np.ndim(mean_e) and np.size(mean_e) > 1:
        # the skewness m / (m + v)**1.5 rises up to m = 2v and falls after it, so over the
        # map it lies between its values at the ends of the map's range (and at 2v when
        # inside): decide from those three numbers when they clear the tolerance by a
        # margin far beyond rounding, instead of a float64 pass over every pixel (7 ms a VGA map)
        lo, hi = float(np.min(mean_e)), float(np.max(mean_e))
        ends = shot_skewness(np.array([lo, hi]), gauss_var_e2)
        peak = float(shot_skewness(2.0 * gauss_var_e2, gauss_var_e2)) if lo < 2 * gauss_var_e2 < hi else 0.0
        top, bottom = max(float(ends.max()), peak), float(ends.min())
        if top < AUTO_SKEW_TOLERANCE * (1 - 1e-9):
            return False
        if bottom > AUTO_SKEW_TOLERANCE * (1 + 1e-9):
            return True
    mask = shot_skewness(mean_e, gauss_var_e2) > AUTO_SKEW_TOLERANCE
    if np.ndim(mask) == 0 or mask.all() or not mask.any():
        return bool(np.all(mask))
    return mask


def poisson_scalar(rng: np.random.Generator, lam: float, shape) -> np.ndarray:
    """Exact Poisson(lam) deviates (float32) for one mean, by the alias method."""
    if lam <= 0:
        return np.zeros(shape, np.float32)
    if lam > 1e6:
        return rng.poisson(lam, size=shape).astype(np.float32)
    lo, prob, alias = alias_table(float(lam))
    idx = rng.integers(0, len(prob), size=shape, dtype=np.int32)
    u = rng.random(size=shape)
    k = np.where(u < prob[idx], idx, alias[idx]).astype(np.float32)
    if lo:
        k += np.float32(lo)
    return k


def poisson_map(rng: np.random.Generator, lam, shape) -> np.ndarray:
    """Exact Poisson deviates (float32) for per-pixel means ``lam`` (broadcast to shape).

    Means up to INVERSION_MAX_MEAN: count the arrivals of a unit-rate Poisson process in
    [0, lam] (sums of float64 Exp(1) draws), about lam + 1 draws per pixel; larger
    means: ``Generator.poisson``.
    """
    lam = np.broadcast_to(np.asarray(lam, np.float64), shape).ravel()
    out = np.zeros(lam.size, np.float32)
    big = lam > INVERSION_MAX_MEAN
    if big.any():
        out[big] = rng.poisson(lam[big])
        idx = np.flatnonzero(~big)
        lam_s = lam[idx]
    else:
        idx, lam_s = None, lam
    res = out if idx is None else np.zeros(lam_s.size, np.float32)
    t = rng.standard_exponential(lam_s.size)  # first arrival time
    act = np.flatnonzero(t <= lam_s)
    k = 0
    while act.size:
        k += 1
        res[act] = k
        ta = t[act] + rng.standard_exponential(act.size)
        t[act] = ta
        act = act[ta <= lam_s[act]]
    if idx is not None:
        out[idx] = res
    return out.reshape(shape)


def shot(rng: np.random.Generator, mean_e, exact, shape, fast: bool, alias: bool = True) -> np.ndarray:
    """One realization of q + delta (float32, e-) for mean ``mean_e`` (scalar or map).

    ``exact`` is True/False or a boolean map choosing exact Poisson per pixel;
    ``alias=False`` avoids building an alias table for a mean used only once.
    """
    if exact is True:
        if np.ndim(mean_e) == 0:
            if alias:
                return poisson_scalar(rng, float(mean_e), shape)
            return rng.poisson(float(mean_e), size=shape).astype(np.float32)
        return poisson_map(rng, mean_e, shape)
    mean_arr = np.broadcast_to(np.asarray(mean_e, np.float32), shape)
    out = normal(rng, shape, fast)
    out *= np.sqrt(mean_arr)
    out += mean_arr
    if exact is not False and exact.any():
        sel = np.broadcast_to(exact, shape)
        out[sel] = poisson_map(rng, mean_arr[sel], (int(np.count_nonzero(sel)),))
    return out
