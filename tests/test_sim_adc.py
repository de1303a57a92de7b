"""ADC: ramp input (test_mode 2), INL/DNL truth vs code histograms, clipping."""

import numpy as np
import pytest

from ares.sim import SensorParams, SimSensor

BITS = 10
P = SensorParams(rows=96, cols=128, adc_bits=BITS).noiseless()


def ramp_widths(params, n=20, seed=0):
    s = SimSensor(params, seed)
    f = s.render_ramp(n)
    counts = np.bincount(f.ravel(), minlength=params.max_code + 1).astype(np.float64)
    per_lsb = f[0].size / (params.max_code + 2.0)  # ramp spans max+2 LSB over one frame
    return s, counts / (n * per_lsb)


def test_ideal_ramp_covers_every_code_uniformly():
    s, w = ramp_widths(P)
    assert w[1:-1] == pytest.approx(1.0, abs=0.02)
    assert w[0] == pytest.approx(1.5, abs=0.02) and w[-1] == pytest.approx(1.5, abs=0.02)  # open ends
    t = s.truth(exposure_s=0.01)
    assert np.all(t["adc"]["inl_lsb"] == 0)
    assert np.all(t["adc"]["dnl_lsb"][1:-1] == 0)


def test_dnl_and_inl_match_truth():
    p = P.replace(adc_dnl_lsb=0.2, adc_inl_lsb=1.5)
    s, w = ramp_widths(p)
    t = s.truth(exposure_s=0.01)["adc"]
    dnl = t["dnl_lsb"]
    assert np.isnan(dnl[0]) and np.isnan(dnl[-1])
    measured = w[1:-1] - 1.0
    assert np.max(np.abs(measured - dnl[1:-1])) < 0.06
    assert np.std(dnl[1:-1]) == pytest.approx(0.2, rel=0.15)
    # INL from the cumulative measured DNL (endpoint fit) reproduces the truth curve
    inl_meas = np.concatenate(([0.0], np.cumsum(measured)))
    assert np.max(np.abs(inl_meas - t["inl_lsb"])) < 0.3
    assert t["inl_lsb"][0] == pytest.approx(0.0, abs=1e-9) and t["inl_lsb"][-1] == pytest.approx(0.0, abs=1e-9)


def test_inl_bow_shape_without_dnl():
    p = P.replace(adc_inl_lsb=2.0)
    s = SimSensor(p, 0)
    inl = s.truth(exposure_s=0.01)["adc"]["inl_lsb"]
    k = np.arange(1, p.max_code + 1)
    assert np.allclose(inl, 2.0 * np.sin(np.pi * (k - 1) / (p.max_code - 1)), atol=1e-9)
    # a noiseless image at mid-scale is shifted by the bow: code = ideal - INL (rounded)
    f = s.render(1, exposure_s=0.01, dark=True, black_level_dn=512)
    assert np.all(f == 512 - 2)


def test_codes_clip_to_the_adc_range():
    p = P.replace(adc_inl_lsb=1.0)
    s = SimSensor(p, 0)
    assert np.all(s.render(1, exposure_s=0.01, dark=True, black_level_dn=5000) == p.max_code)
    assert np.all(s.render(1, exposure_s=0.01, dark=True, black_level_dn=-10) == 0)


@pytest.mark.parametrize("bits, inl, dnl, seed", [(12, 0.5, 0.0, 0), (12, 1.5, 0.1, 1), (10, 3.0, 0.6, 2),
                                                  (8, 0.0, 0.9, 3), (14, 2.0, 0.3, 4)])
def test_table_lookup_is_bit_identical_to_searchsorted(bits, inl, dnl, seed):
    """The lookup-table ADC (Adc._lookup) gives searchsorted's codes for every input,
    including values exactly at, and one float32 step below, each transition level and
    values far outside the range."""
    from ares.sim.adc import Adc

    a = Adc(SensorParams(rows=8, cols=8, adc_bits=bits, adc_inl_lsb=inl, adc_dnl_lsb=dnl), np.random.default_rng(seed))
    t32 = a.thresholds.astype(np.float32)
    x = np.concatenate([
        np.random.default_rng(seed).uniform(-20, a.max_code + 20, 200_000).astype(np.float32),
        t32, np.nextafter(t32, np.float32(-np.inf)), np.nextafter(t32, np.float32(np.inf)),
        np.array([-1e30, 1e30, -0.5, 0.5, 0, a.max_code - 0.5, a.max_code + 0.5, a.max_code + 1.5], np.float32)])
    np.testing.assert_array_equal(a._lookup(x), np.searchsorted(a.thresholds, x, side="right"))
