"""ADC INL/DNL per channel from code-density (ramp and sine) and ramp transitions."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.ptc.adc import code_density, per_channel, ramp_transitions


def make_adc(rng, m=1023, dnl=0.2, inl=1.5):
    w = np.clip(1 + dnl * rng.standard_normal(m - 1), 0, None)
    w *= (m - 1) / w.sum()
    T = 0.5 + np.concatenate(([0], np.cumsum(w)))
    T += inl * np.sin(np.pi * (T - 0.5) / (m - 1))
    T = np.maximum.accumulate(T)
    return T, T - (np.arange(1, m + 1) - 0.5), np.diff(T) - 1


@pytest.fixture(scope="module")
def adc():
    return make_adc(np.random.default_rng(1))


def test_code_density_ramp_per_channel(adc):
    T, inl, dnl = adc
    m = T.size
    rng = np.random.default_rng(2)
    x = np.linspace(-1, m + 1, 64 * 128)
    frames = np.stack([np.searchsorted(T, x + rng.uniform(0, 2 * (x[1] - x[0])), side="right").reshape(64, 128)
                       for _ in range(40)]).astype(np.uint16)
    res = per_channel(frames, m, "code_density")
    assert len(res) == 2
    for r in res:
        assert r.inl_max == pytest.approx(np.max(inl), abs=0.05)
        assert r.inl_min == pytest.approx(np.min(inl), abs=0.05)
        assert r.dnl_max == pytest.approx(np.max(dnl), abs=0.05)
        assert r.dnl_min == pytest.approx(np.min(dnl), abs=0.05)
    rr = per_channel(frames, m, "ramp")
    assert rr[0].inl_max == pytest.approx(np.max(inl), abs=0.05)


def test_ramp_with_known_input_gives_absolute_levels(adc):
    T, inl, _ = adc
    m = T.size
    step = 0.01
    x = -1 + step * np.arange(int((m + 2) / step))
    codes = np.searchsorted(T, x, side="right")[None]
    r = ramp_transitions(codes, m, x0=-1.0, step=step)
    assert np.nanmax(np.abs(r.inl - inl)) < 0.02


def test_sine_histogram(adc):
    T, inl, dnl = adc
    m = T.size
    ph = np.linspace(0, 2 * np.pi, 2_000_000, endpoint=False) + 0.123
    codes = np.searchsorted(T, m / 2 + (m / 2 + 3) * np.sin(ph), side="right")
    r = code_density(codes, m, "sine")
    assert np.nanmax(np.abs(r.inl - inl)) < 0.05
    assert np.nanmax(np.abs(r.dnl[1:-1] - dnl)) < 0.05


def test_missing_codes_reported():
    T = np.arange(1, 256) - 0.5
    T[100] = T[99]  # code 100 has zero width
    x = np.linspace(-1, 256, 100000)
    r = code_density(np.searchsorted(T, x, side="right"), 255)
    assert 100 in r.missing_codes and r.dnl[100] == pytest.approx(-1, abs=0.01)
