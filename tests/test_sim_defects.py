"""Defects are where truth says, and behave as their class says."""

import numpy as np
import pytest

from ares.sim import SensorParams, SimSensor

P = SensorParams(rows=48, cols=64, hot_rate_ppm=3000, warm_rate_ppm=3000, rts_rate_ppm=3000,
                 dead_rate_ppm=3000, stuck_rate_ppm=2000, noisy_rate_ppm=3000, bad_columns=2,
                 rts_amplitude_e=200.0, rts_switch_prob=0.2, ob_columns=4)
N = P.rows * P.cols


@pytest.fixture(scope="module")
def sensor():
    return SimSensor(P, 21)


def test_counts_disjoint_and_outside_ob(sensor):
    d = sensor.truth(exposure_s=0.01)["defects"]
    seen = set()
    for name in ("hot", "warm", "rts", "dead", "stuck", "noisy"):
        r, c = d[name]
        assert len(r) == round(getattr(P, f"{name}_rate_ppm") * 1e-6 * N)
        assert np.all(c >= P.ob_columns)
        flat = set((r * P.cols + c).tolist())
        assert not flat & seen
        seen |= flat
    assert len(d["bad_columns"]) == 2 and np.all(d["bad_columns"] >= P.ob_columns)


def test_hot_and_warm_pixels_in_long_darks(sensor):
    kw = dict(exposure_s=1.0, temperature_c=60.0, dark=True)
    t = sensor.truth(**kw)
    f = sensor.render(4, **kw).astype(np.float64).mean(axis=0)
    med = np.median(f)
    G = t["G"]
    hr, hc = t["defects"]["hot"]
    expect = G * t["defects"]["properties"]["hot_e_per_s"]
    assert np.allclose(f[hr, hc] - med, expect, rtol=0.1, atol=10)
    wr, wc = t["defects"]["warm"]
    assert np.allclose(f[wr, wc] - med, G * t["defects"]["properties"]["warm_e_per_s"], rtol=0.15, atol=10)
    assert np.allclose(t["maps"]["dark_e_per_s"][hr, hc], 50 + t["defects"]["properties"]["hot_e_per_s"], rtol=0.5)


def test_dead_pixels_respond_weakly(sensor):
    kw = dict(exposure_s=0.01, photon_flux=1e6)
    t = sensor.truth(**kw)
    f = sensor.render(4, **kw).astype(np.float64).mean(axis=0) - t["o"]
    r, c = t["defects"]["dead"]
    ratio = f[r, c] / np.median(f[:, P.ob_columns:])
    assert np.allclose(ratio, P.dead_response, atol=0.05)
    assert np.allclose(t["maps"]["gain_dn_per_e"][r, c] / t["G"], P.dead_response, rtol=0.1)


def test_stuck_pixels_hold_their_code(sensor):
    t = sensor.truth(exposure_s=0.01)
    r, c = t["defects"]["stuck"]
    for kw in (dict(dark=True), dict(photon_flux=1e6)):
        f = sensor.render(3, exposure_s=0.01, **kw)
        assert np.all(f[:, r, c] == t["defects"]["properties"]["stuck_code"])


def test_noisy_pixels_have_more_temporal_noise(sensor):
    t = sensor.truth(exposure_s=0.001, dark=True)
    f = sensor.render(40, exposure_s=0.001, dark=True).astype(np.float64)
    sd = f.std(axis=0, ddof=1)
    r, c = t["defects"]["noisy"]
    normal_sd = np.median(sd)
    expect = np.sqrt((P.noisy_factor * t["read_noise_dn"]) ** 2 + P.chain_noise_dn**2 + 1 / 12)
    assert np.all(sd[r, c] > 2 * normal_sd)
    assert np.median(sd[r, c]) == pytest.approx(expect, rel=0.25)


def test_rts_pixels_are_bistable(sensor):
    t = sensor.truth(exposure_s=0.001, dark=True)
    f = sensor.render(100, exposure_s=0.001, dark=True).astype(np.float64)
    r, c = t["defects"]["rts"]
    amp = t["G"] * t["defects"]["properties"]["rts_amplitude_e"]
    for i in range(len(r)):
        series = f[:, r[i], c[i]]
        lo, hi = series.min(), series.max()
        assert hi - lo == pytest.approx(amp[i], abs=12)
        mid = (lo + hi) / 2
        assert 5 < np.sum(series > mid) < 95  # both levels visited


def test_bad_columns_are_offset(sensor):
    t = sensor.truth(exposure_s=0.01, dark=True)
    f = sensor.render(2, exposure_s=0.01, dark=True).astype(np.float64).mean(axis=(0, 1))
    bad = t["defects"]["bad_columns"]
    good = np.setdiff1d(np.arange(P.cols), bad)
    assert np.all(f[bad] - np.median(f[good]) > P.bad_column_offset_dn - 6)
