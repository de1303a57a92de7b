"""Characterization analyses against the simulator's ground truth (ares.sim).

Small sensors, seconds per test. Defect pixels are switched off where they would bias a
whole-array statistic the truth does not include; each test says which truth it uses.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

sim = pytest.importorskip("ares.sim", reason="the simulator (ares.sim) is not available")
from ares.sim import SensorParams, SimSensor  # noqa: E402

from ares.analysis.ptc.adc import per_channel  # noqa: E402
from ares.analysis.ptc.dark_current import dark_current, doubling_temperature, dsnu_vs_exposure  # noqa: E402
from ares.analysis.ptc.gain_split import split_noise  # noqa: E402
from ares.analysis.ptc.lag import lag_from_sequence  # noqa: E402
from ares.analysis.ptc.levels import pair_stats, stack_stats  # noqa: E402
from ares.analysis.ptc.photon_transfer import analyze_ptc  # noqa: E402

NO_DEFECTS = dict(hot_rate_ppm=0, warm_rate_ppm=0, rts_rate_ppm=0, dead_rate_ppm=0, stuck_rate_ppm=0,
                  noisy_rate_ppm=0)


@pytest.fixture(scope="module")
def ptc_run():
    p = SensorParams(rows=256, cols=256, **NO_DEFECTS)
    s = SimSensor(p, 11)
    t = 0.01
    q = np.concatenate([np.geomspace(50, 11000, 22), [12500, 14000, 17000, 22000]])
    bright = [stack_stats(s.render(6, exposure_s=t, photon_flux=x / (p.qe * t)), p.max_code) for x in q]
    dark = stack_stats(s.render(16, exposure_s=t, dark=True), p.max_code)
    res = analyze_ptc(bright, [dark] * len(bright), photons=q / p.qe, adc_lsb_uv=p.adc_lsb_uv)
    return p, s.truth(exposure_s=t, photon_flux=1000.0), res, q


def test_conversion_gain(ptc_run):
    p, truth, r, _ = ptc_run
    G = truth["G"]
    e = r.gain_dn_per_e  # ARES primary: weighted least squares
    assert abs(e.value / G - 1) < 0.003 and abs(e.value - G) <= 3 * e.se, e
    # the Astier fit (one more parameter) and the unweighted EMVA origin fit are noisier:
    # within 3 of their (larger) standard errors
    for e in (r.gain_astier_dn_per_e, r.gain_origin_dn_per_e):
        assert abs(e.value - G) <= 3 * e.se and abs(e.value / G - 1) < 0.005, e
    assert r.conversion_gain_uv_per_e.value == pytest.approx(p.conversion_gain_uv_per_e, rel=0.003)


def test_read_noise(ptc_run):
    """ARES read noise = all dark temporal noise, input-referred, quantization removed:
    truth sqrt(Pt + Ct + Rt)/G (the pair/stack formula removes the frame-global term)."""
    _, truth, r, _ = ptc_run
    expect = math.sqrt(truth["Pt"] + truth["Ct"] + truth["Rt"]) / truth["G"]
    assert r.read_noise_e.value == pytest.approx(expect, rel=0.01)
    assert not r.read_noise_is_upper_limit


def test_full_well(ptc_run):
    _, truth, r, _ = ptc_run
    fw = r.full_well_e
    assert fw["plateau"].value == pytest.approx(truth["full_well_e"], rel=0.01)
    # the variance peak sits a few shot-noise sigmas below the charge capacity
    assert 0.9 * truth["full_well_e"] < fw["max_variance"].value < truth["full_well_e"]
    assert not fw["max_code"].available and "maximum code" in fw["max_code"].note


def test_saturated_levels_excluded_with_reason(ptc_run):
    _, truth, r, q = ptc_run
    ex = dict(r.excluded())
    assert {i for i, x in enumerate(q) if x > 1.05 * truth["full_well_e"]} <= set(ex)
    assert all(ex.values())
    assert all(q[lv.index] < truth["full_well_e"] for lv in r.used("fit"))


def test_dark_current_and_doubling_temperature():
    p = SensorParams(rows=64, cols=64, **NO_DEFECTS, dark_tail_e_per_s=0.0)
    s = SimSensor(p, 5)
    temps = [40.0, 50.0, 60.0, 70.0, 80.0]
    texp = np.array([0.001, 0.5, 1.0, 1.5, 2.0, 3.0])
    rates, ses, dsnu = [], [], []
    for T in temps:
        st = [pair_stats(*s.render(2, exposure_s=t, dark=True, temperature_c=T)) for t in texp]
        dc = dark_current(texp, [x.mean for x in st], p.gain_dn_per_e(), [x.var for x in st])
        tr = s.truth(exposure_s=1.0, dark=True, temperature_c=T)
        assert abs(dc.rate_e_per_s.value - tr["dark_current_e_per_s"]) <= 4 * dc.rate_e_per_s.se
        assert dc.rate_from_variance_e_per_s.value == pytest.approx(tr["dark_current_e_per_s"], rel=0.25)
        rates.append(dc.rate_e_per_s.value)
        ses.append(dc.rate_e_per_s.se)
        dsnu.append(dsnu_vs_exposure(texp, [math.sqrt(max(x.spatial_var, 0)) for x in st],
                                     p.gain_dn_per_e()).dsnu_e_per_s.value)
    td = doubling_temperature(temps, rates, ses)
    assert td.doubling_c.value == pytest.approx(p.dark_doubling_c, rel=0.05)
    assert td.value_at_ref.value == pytest.approx(p.dark_current_e_per_s, rel=0.05)
    tdd = doubling_temperature(temps, dsnu)
    assert tdd.doubling_c.value == pytest.approx(p.dark_doubling_c, rel=0.1)


def test_pixel_chain_noise_split():
    """Row/column temporal noise (DN at the ADC input) would join the chain term: off here,
    so the truth is read_noise_e (pixel) and chain_noise_dn (chain)."""
    p = SensorParams(rows=128, cols=128, **NO_DEFECTS, col_temporal_dn=0.0, row_temporal_dn=0.0,
                     read_noise_e=2.5, chain_noise_dn=0.8)
    s = SimSensor(p, 9)
    gains = [1.0, 2.0, 4.0, 8.0, 16.0]
    var, se = [], []
    for g in gains:
        st = stack_stats(s.render(8, exposure_s=0.001, dark=True, analog_gain=g))
        var.append(st.var)
        se.append(st.var_se)
    r = split_noise([p.gain_dn_per_e(g) for g in gains], var, se)
    assert r.pixel_noise_e.value == pytest.approx(p.read_noise_e, rel=0.05)
    assert r.chain_noise_dn.value == pytest.approx(p.chain_noise_dn, rel=0.05)


def test_adc_inl_dnl_per_channel():
    p = SensorParams(rows=256, cols=256, adc_bits=10, adc_inl_lsb=1.5, adc_dnl_lsb=0.15, **NO_DEFECTS)
    s = SimSensor(p, 3)
    frames = s.render_ramp(24)
    truth = s.truth()["adc"]
    inl = np.asarray(truth["inl_lsb"], float)
    dnl = np.asarray(truth["dnl_lsb"], float)
    for method in ("code_density", "ramp"):
        for r in per_channel(frames, p.max_code, method):
            assert r.inl_max == pytest.approx(np.nanmax(inl), abs=0.05)
            assert r.inl_min == pytest.approx(np.nanmin(inl), abs=0.05)
            assert r.dnl_max == pytest.approx(np.nanmax(dnl), abs=0.05)
            assert r.dnl_min == pytest.approx(np.nanmin(dnl), abs=0.05)


def test_image_lag():
    p = SensorParams(rows=64, cols=64, lag_fraction=0.03, **NO_DEFECTS)
    s = SimSensor(p, 2)
    frames, lit = [], []
    t, flux = 0.01, 8000 / (p.qe * 0.01)
    for _ in range(4):
        frames.append(s.render(4, exposure_s=t, photon_flux=flux))
        lit += [True] * 4
        frames.append(s.render(4, exposure_s=t, dark=True))
        lit += [False] * 4
    r = lag_from_sequence(np.concatenate(frames), lit)
    assert r.lag_pct.value == pytest.approx(100 * s.truth(exposure_s=t)["lag_fraction"], abs=0.1)
    assert r.cycles == 4


def test_emva_dark_current_from_variance_against_truth():
    """EMVA 1288 4.0 Section 7.1: the dark-variance slope (DN^2/s) divided by K^2 -- the
    dark shot noise of a dark current I e-/s adds I*t e-^2. It once used sqrt(slope)/K
    (10x low here)."""
    from ares.analysis.emva.release3 import emva1288_results, temporal_from_pairs

    p = SensorParams(rows=128, cols=128, **NO_DEFECTS, dark_tail_e_per_s=0.0, dark_current_e_per_s=200.0)
    s = SimSensor(p, 21)
    texp = np.linspace(0.05, 0.5, 6)
    darks = [s.render(2, exposure_s=t, dark=True) for t in texp]
    ne = np.linspace(300, 3000, texp.size)
    brights = [s.render(2, exposure_s=t, photon_flux=n / (p.qe * t)) for t, n in zip(texp, ne)]
    td = temporal_from_pairs(brights, darks, texp, ne / p.qe, offset_correction=True)
    r = emva1288_results(td, index_u_ysat=len(texp) - 1)
    truth = s.truth(exposure_s=1.0, dark=True)["dark_current_e_per_s"]
    var_rate = r.extra["u_I_var"]
    assert abs(var_rate.value - truth) < 4 * var_rate.se and var_rate.value == pytest.approx(truth, rel=0.15)
    assert r.values["u_I_mean"].value == pytest.approx(truth, rel=0.1)
