"""Pixel/chain noise split from dark noise at several analog gains."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.ptc.gain_split import input_referred_noise_e, pixel_noise_uv, split_noise
from ares.analysis.ptc.levels import pair_stats


def test_split_recovers_pixel_and_chain_noise():
    rng = np.random.default_rng(7)
    K1, pix_e, chain_dn = 0.1, 4.0, 1.2
    gains = np.array([1, 2, 4, 8, 16])
    var, se = [], []
    for g in gains:
        K = K1 * g
        fr = [np.round(K * rng.normal(0, pix_e, (200, 200)) + rng.normal(0, chain_dn, (200, 200)) + 500)
              for _ in range(2)]
        st = pair_stats(*fr)
        var.append(st.var)
        se.append(st.var_se)
    r = split_noise(K1 * gains, var, se)
    assert r.pixel_noise_e.value == pytest.approx(pix_e, rel=0.03)
    assert r.chain_noise_dn.value == pytest.approx(chain_dn, rel=0.03)
    assert r.crossover_gain_dn_per_e.value == pytest.approx(chain_dn / pix_e, rel=0.05)
    assert pixel_noise_uv(r, 70.0).value == pytest.approx(70.0 * r.pixel_noise_e.value)
    model = input_referred_noise_e(r, K1 * gains)
    assert model[0] > model[-1]  # chain noise dominates input-referred noise at low gain


def test_split_needs_two_gains():
    r = split_noise([0.2, 0.2], [3.0, 3.1])
    assert not r.pixel_noise_e.available and "2 different gains" in r.pixel_noise_e.note
