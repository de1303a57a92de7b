"""A hot/warm claim needs a series a steady dark rate shows (ares.analysis.defects.steady,
issue 48): against the closed form, steady pixels lose their claim at the designed rate and
the pixels that made warm imprecise -- an offset without its shot noise (a trap held high),
a noisy pixel with a raised mean -- lose it nearly always; where most claimed pixels fail, K
(or the model) is what is wrong, and the variance is not used."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from ares.analysis.defects.steady import P_VARIANCE_SIDE, shot_noise_could_explain, variance_unsteady

POP, FPN, K, F = 4.0, 1.0, 0.5, 16


def _level(excess, temporal_var, rng):
    """One dark level of n pixels (a 1 x n map): F Gaussian frames each, mean ``excess`` DN
    over the population, its own offset (FPN) on top, temporal variance ``temporal_var``."""
    n = excess.size
    x = excess + FPN * rng.standard_normal(n) + np.sqrt(temporal_var) * rng.standard_normal((F, n))
    st = SimpleNamespace(n_frames=F, var=x.var(axis=0, ddof=1)[None, :], code_step=None)
    return SimpleNamespace(st=st, res=x.mean(axis=0)[None, :], pop_var=POP, sigma=math.sqrt(FPN**2 + POP / F))


def _flagged(d, gain=K):
    n = d.res.shape[1]
    return variance_unsteady([d], np.zeros(n, np.intp), np.arange(n), gain, 1)


def _join(*levels):
    st = SimpleNamespace(n_frames=F, var=np.concatenate([d.st.var for d in levels], axis=1), code_step=None)
    return SimpleNamespace(st=st, res=np.concatenate([d.res for d in levels], axis=1), pop_var=POP,
                           sigma=levels[0].sigma)


def test_steady_rates_lose_their_claim_at_the_designed_rate():
    """Steady dark rates (5-200 DN of excess, variance = population + K x excess): flagged
    at most at the two sides' P_VARIANCE_SIDE together (the lower side is conservative: it
    allows for the pixel's own offset), within 4 binomial SE; the upper side alone near its
    nominal rate."""
    rng = np.random.default_rng(48_101)
    n = 30_000
    ex = rng.uniform(5.0, 200.0, n)
    d = _level(ex, POP + K * ex, rng)
    flagged, note = _flagged(d)
    rate = float(flagged.mean())
    assert not note
    se = math.sqrt(2 * P_VARIANCE_SIDE / n)
    assert rate <= 2 * P_VARIANCE_SIDE + 4 * se, rate
    assert rate >= P_VARIANCE_SIDE - 4 * math.sqrt(P_VARIANCE_SIDE / n), rate


def test_offsets_without_shot_noise_and_noisy_pixels_are_no_steady_rate():
    """Among steady hot pixels, traps held high (60 DN of offset, the population's variance
    only) and noisy pixels (8 DN of temporal noise) with a 10 DN mean: no steady rate in >= 95
    % of the cases, the steady ones in <= 2 %."""
    rng = np.random.default_rng(48_102)
    n = 1_000
    ex = rng.uniform(5.0, 200.0, 3 * n)
    mix = _join(_level(ex, POP + K * ex, rng), _level(np.full(n, 60.0), np.full(n, POP), rng),
                _level(np.full(n, 10.0), np.full(n, 64.0), rng))
    flagged, note = _flagged(mix)
    assert not note and flagged[:3 * n].mean() <= 0.02
    assert flagged[3 * n:4 * n].mean() >= 0.95 and flagged[4 * n:].mean() >= 0.95


def test_a_wrong_gain_is_not_read_as_unsteady_pixels():
    """Steady hot pixels judged with K 2x too high or 3x too low, and offsets without any shot
    noise (as in benchmarks/bench_defects.py): the K their own variance shows (or most of them
    failing) says the K given is wrong -- nothing is withheld, and the note says why; with K
    1.3x off the test still runs (within K_FACTOR) and withholds ~1 %."""
    rng = np.random.default_rng(48_103)
    ex = rng.uniform(20.0, 200.0, 500)
    steady = _level(ex, POP + K * ex, rng)
    for d, gain in ((steady, 2 * K), (steady, K / 3), (_level(ex, np.full(ex.size, POP), rng), K)):
        flagged, note = _flagged(d, gain=gain)
        assert not flagged.any() and "check K" in note, note
    flagged, note = _flagged(steady, gain=1.3 * K)
    assert not note and flagged.mean() < 0.03


def _quiet(signal, extra_var, rng, pop, fpn, frames=256):
    """One dark level of n pixels: a dark signal ``signal`` DN (its shot noise K x signal in the
    variance), their own offset (FPN), ``extra_var`` DN^2 of excess read noise; the variances
    drawn as chi-square over ``frames`` - 1 dof."""
    n = signal.size
    res = signal + fpn * rng.standard_normal(n) + np.sqrt((pop + K * signal + extra_var) / frames) * rng.standard_normal(n)
    var = (pop + K * signal + extra_var) * rng.chisquare(frames - 1, n) / (frames - 1)
    st = SimpleNamespace(n_frames=frames, var=var[None, :], code_step=None)
    return SimpleNamespace(st=st, res=res[None, :], pop_var=pop, sigma=math.sqrt(fpn**2 + pop / frames))


def test_a_dark_signal_its_offset_hides_is_not_read_as_noisy():
    """Issue 48: on a quiet sensor (0.5 DN of noise and FPN, K 0.5, 256 frames) a dark signal of
    0.15-3.5 DN whose negative offset hides it raises the variance beyond the shot noise of its
    measured excess (the noisy test's allowance): the shot noise of a signal its excess does not
    rule out explains it, in all but P_VARIANCE_SIDE (4 binomial SE). Noisy pixels without a dark
    signal of 3-10x the temporal noise are not explained (<= 0.5 %; of 1.5-2x most are: there the
    two give the same data); nor at 2 DN of noise and 1 DN of FPN a noisy pixel of 1.5x, the
    family's weakest (<= 0.1 %: the allowance is inside the noisy test's own margin)."""
    rng = np.random.default_rng(48_104)
    n = 20_000
    idx = np.zeros(n, np.intp), np.arange(n)
    dark = _quiet(rng.uniform(0.15, 3.5, n), np.zeros(n), rng, 0.25, 0.5)
    rate = 1.0 - float(shot_noise_could_explain([dark], *idx, K, 1).mean())
    assert rate <= P_VARIANCE_SIDE + 4 * math.sqrt(P_VARIANCE_SIDE / n), rate
    noisy = _quiet(np.zeros(n), 0.25 * (rng.uniform(3.0, 10.0, n) ** 2 - 1), rng, 0.25, 0.5)
    assert shot_noise_could_explain([noisy], *idx, K, 1).mean() <= 5e-3
    weak = _quiet(np.zeros(n), 0.25 * (rng.uniform(1.5, 2.0, n) ** 2 - 1), rng, 0.25, 0.5)
    assert shot_noise_could_explain([weak], *idx, K, 1).mean() >= 0.5
    loud = _quiet(np.zeros(n), np.full(n, 4.0 * (1.5**2 - 1)), rng, 4.0, 1.0)
    assert shot_noise_could_explain([loud], *idx, K, 1).mean() <= 1e-3

