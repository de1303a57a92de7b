"""Dark current vs exposure and temperature on local synthetic darks (known truth)."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.ptc.dark_current import dark_current, doubling_temperature, dsnu_vs_exposure
from ares.analysis.ptc.levels import pair_stats


def darks(rng, t, rate_map, K=0.3, read_e=3.0, offset=100.0, shape=(96, 96)):
    out = []
    for _ in range(2):
        q = rng.poisson(rate_map * t)
        out.append(np.round(K * (q + rng.normal(0, read_e, shape)) + offset).astype(np.uint16))
    return np.stack(out)


def test_dark_current_from_mean_and_variance():
    rng = np.random.default_rng(2)
    rate = np.full((96, 96), 40.0)
    t = np.array([0.01, 0.5, 1, 2, 3, 4, 5])
    st = [pair_stats(*darks(rng, x, rate)) for x in t]
    r = dark_current(t, [s.mean for s in st], 0.3, [s.var for s in st])
    assert abs(r.rate_e_per_s.value - 40) < 4 * r.rate_e_per_s.se + 0.2
    assert r.rate_from_variance_e_per_s.value == pytest.approx(40, rel=0.1)
    few = dark_current(t[:4], [s.mean for s in st[:4]], 0.3)
    assert not few.rate_e_per_s.available and ">= 6" in few.rate_e_per_s.note


def test_dsnu_vs_exposure():
    t = np.array([0.0, 0.5, 1, 2, 4, 8])
    A, D = 2.0, 1.5
    s = np.sqrt(A**2 + (t * D) ** 2)
    f = dsnu_vs_exposure(t, s, 0.5)
    assert f.a_dn.value == pytest.approx(A, rel=1e-6)
    assert f.dsnu_dn_per_s.value == pytest.approx(D, rel=1e-6)
    assert f.dsnu_e_per_s.value == pytest.approx(3.0, rel=1e-6)


def test_doubling_temperature_log2_fit():
    rng = np.random.default_rng(4)
    T = np.array([20, 30, 40, 50, 60, 70])
    x = 12.0 * 2 ** ((T - 60) / 8.0) * (1 + 0.01 * rng.standard_normal(T.size))
    f = doubling_temperature(T, x, 0.01 * x)
    assert f.doubling_c.value == pytest.approx(8.0, rel=0.02)
    assert abs(f.doubling_c.value - 8.0) < 4 * f.doubling_c.se
    assert f.value_at_ref.value == pytest.approx(12.0, rel=0.03)
