"""Image lag from a bright->dark sequence with a known carried-over fraction."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.lag import image_lag, lag_from_sequence


def sequence(rng, lag=0.02, cycles=5, n_bright=4, n_dark=4, q=8000.0, K=0.3, shape=(64, 64)):
    frames, lit, carry = [], [], np.zeros(shape)
    for _ in range(cycles):
        for on in [True] * n_bright + [False] * n_dark:
            charge = rng.poisson(q, shape) if on else np.zeros(shape)
            out = (1 - lag) * charge + carry
            carry = lag * charge
            frames.append(np.round(K * (out + rng.normal(0, 3, shape)) + 100))
            lit.append(on)
    return np.array(frames), np.array(lit)


def test_lag_fraction_recovered():
    f, lit = sequence(np.random.default_rng(0))
    r = lag_from_sequence(f, lit)
    assert r.cycles == 5
    assert r.lag_pct.value == pytest.approx(2.0, abs=0.1)
    assert abs(r.lag_pct.value - 2.0) < 5 * r.lag_pct.se


def test_no_lag_and_missing_parts():
    f, lit = sequence(np.random.default_rng(1), lag=0.0, cycles=1)
    r = lag_from_sequence(f, lit)
    assert abs(r.lag_pct.value) < 0.1 and "pixel scatter" in r.lag_pct.note
    assert not lag_from_sequence(f[:4], lit[:4]).lag_pct.available
    assert not image_lag(f[4:], f[5], f[6:]).lag_pct.available
