"""Each ARTEMIS component, isolated by switching the others off, matches its truth.

Tolerances: a variance estimate with df degrees of freedom has relative standard error
sqrt(2/df); we allow 4 of them. Quantization adds 1/12 DN^2 (Sheppard) for sigmas of a
few DN, and is subtracted.
"""

import numpy as np
import pytest

from ares.sim import SensorParams, SimSensor

BASE = SensorParams(rows=48, cols=64).noiseless()
Q12 = 1.0 / 12.0


def tol(var, df, k=4.0):
    return k * np.sqrt(2.0 / df) * var


def frames(params, n=16, seed=3, **kw):
    kw.setdefault("exposure_s", 0.01)
    return SimSensor(params, seed).render(n, **kw).astype(np.float64)


def test_noiseless_dark_frame_is_the_black_level():
    f = frames(BASE, n=2, dark=True, black_level_dn=100)
    assert np.all(f == 100)


def test_pixel_temporal_read_noise():
    p = BASE.replace(read_noise_e=10.0)  # G = 0.28 -> 2.8 DN
    f = frames(p, n=20)
    v = f.var(axis=0, ddof=1).mean() - Q12
    expect = SimSensor(p, 3).truth(exposure_s=0.01)["Pt"]
    assert expect == pytest.approx(2.8**2)
    assert abs(v - expect) < tol(expect, p.rows * p.cols * 19)


def test_chain_noise_does_not_scale_with_analog_gain_but_read_noise_does():
    p = BASE.replace(read_noise_e=5.0, chain_noise_dn=2.0)
    for gain in (1.0, 4.0):
        f = frames(p, n=20, analog_gain=gain)
        v = f.var(axis=0, ddof=1).mean() - Q12
        expect = (5.0 * 0.28 * gain) ** 2 + 4.0
        assert SimSensor(p, 3).truth(exposure_s=0.01, analog_gain=gain)["Pt"] == pytest.approx(expect)
        assert abs(v - expect) < tol(expect, p.rows * p.cols * 19)


def test_row_temporal_noise():
    p = BASE.replace(row_temporal_dn=3.0)
    f = frames(p, n=30)
    rows = f.mean(axis=2)  # (F, R); every pixel of a row is equal
    v = rows.var(ddof=1) - Q12
    assert abs(v - 9.0) < tol(9.0, 30 * p.rows - 1)
    assert np.all(f.std(axis=2) == 0)


def test_column_temporal_noise():
    p = BASE.replace(col_temporal_dn=3.0)
    f = frames(p, n=30)
    cols = f.mean(axis=1)
    v = cols.var(ddof=1) - Q12
    assert abs(v - 9.0) < tol(9.0, 30 * p.cols - 1)
    assert np.all(f.std(axis=1) == 0)


def test_frame_global_noise():
    p = BASE.replace(frame_global_dn=3.0)
    f = frames(p, n=200)
    g = f[:, 0, 0]
    assert np.all(f == g[:, None, None])
    assert abs(g.var(ddof=1) - Q12 - 9.0) < tol(9.0, 199)


def test_offset_fixed_patterns_equal_truth_maps():
    p = BASE.replace(col_fpn_dn=5.0, row_fpn_dn=4.0, pixel_fpn_e=20.0, adc_offset_dn=(0.0, 3.0))
    s = SimSensor(p, 11)
    f = s.render(2, exposure_s=0.01, dark=True).astype(np.float64)
    t = s.truth(exposure_s=0.01, dark=True)
    m = t["maps"]
    expected = t["realized"]["o"] + m["Cs"][None, :] + m["Rs"][:, None] + m["Ps"]
    assert np.all(np.abs(f - np.round(expected)) <= 1) and np.mean(f == np.round(expected)) > 0.99
    # realized variances against the parameters (df = C-1, R-1, ~R*C)
    assert abs(t["realized"]["Cs"] - t["Cs"]) < tol(t["Cs"], p.cols - 1)
    assert t["Cs"] == pytest.approx(25.0 + 1.5**2)
    assert abs(t["realized"]["Rs"] - 16.0) < tol(16.0, p.rows - 1)
    ps = (20.0 * 0.28) ** 2
    assert t["Ps"] == pytest.approx(ps)
    assert abs(t["realized"]["Ps"] - ps) < tol(ps, p.rows * p.cols - 1)


def test_adc_channels_offsets_and_gains():
    p = BASE.replace(adc_offset_dn=(2.0, 9.0))
    f = frames(p, n=1, dark=True, black_level_dn=50)
    assert np.all(f[:, :, 0::2] == 52) and np.all(f[:, :, 1::2] == 59)
    p = BASE.replace(adc_gain=(1.0, 1.1))
    flat = frames(p, n=8, photon_flux=1.0e6, black_level_dn=0.0)  # q = 6000 e-, below full well
    ratio = flat[:, :, 1::2].mean() / flat[:, :, 0::2].mean()
    assert ratio == pytest.approx(1.1, rel=2e-3)


def test_gain_maps_and_shot_noise_of_a_flat():
    p = BASE.replace(prnu_pct=(2.0, 1.0, 3.0, 0.5), col_gain_pct=1.0, row_gain_pct=0.5)
    s = SimSensor(p, 5)
    kw = dict(exposure_s=0.01, photon_flux=1.0e6)  # q = 6000 e-
    f = s.render(16, **kw).astype(np.float64)
    t = s.truth(**kw)
    expected = t["o"] + t["maps"]["gain_dn_per_e"] * t["q"]
    resid = f.mean(axis=0) - expected
    # residual = mean of 16 frames of shot noise + quantization
    var = float(np.mean(t["maps"]["gain_dn_per_e"] ** 2 * t["q"]) + Q12) / 16
    assert abs(resid.mean()) < 4 * np.sqrt(var / resid.size)
    assert abs(resid.var() - var) < tol(var, resid.size)
    # temporal variance = G^2 CgRgPg^2 q (+1/12)
    tv = f.var(axis=0, ddof=1).mean() - Q12
    assert abs(tv - var * 16 + Q12) < tol(var * 16, resid.size * 15)
    for i, pct in enumerate(p.prnu_pct):
        real = t["realized"]["Pg_by_phase"][i]
        assert abs(real - (pct / 100) ** 2) < tol((pct / 100) ** 2, p.rows * p.cols // 4 - 1)


def test_analog_gain_scales_signal_and_shot_noise():
    p = BASE
    kw = dict(exposure_s=0.01, photon_flux=5.0e5, black_level_dn=0.0)  # q = 3000 e-
    f1 = frames(p, n=8, analog_gain=1.0, **kw)
    f2 = frames(p, n=8, analog_gain=2.0, **kw)
    assert f2.mean() / f1.mean() == pytest.approx(2.0, rel=1e-3)
    v1 = f1.var(axis=0, ddof=1).mean() - Q12
    v2 = f2.var(axis=0, ddof=1).mean() - Q12
    assert v2 / v1 == pytest.approx(4.0, rel=4 * np.sqrt(2 * 2 / (p.rows * p.cols * 7)))


def test_full_well_and_adc_clipping():
    p = BASE
    t = SimSensor(p, 0).truth(exposure_s=0.01)
    f = frames(p, n=2, photon_flux=1e9, black_level_dn=64)
    assert np.all(f == np.round(64 + t["full_well_dn"]))
    f = frames(p, n=2, photon_flux=1e9, analog_gain=4.0)
    assert np.all(f == p.max_code)
    f = frames(p, n=2, dark=True, black_level_dn=-50)
    assert np.all(f == 0)


def test_full_well_clips_photo_plus_dark_charge():
    p = BASE.replace(dark_current_e_per_s=4000.0)
    f = frames(p, n=2, exposure_s=1.0, temperature_c=60.0, photon_flux=20000.0, black_level_dn=0)
    assert np.all(f == np.round(0.28 * p.full_well_e))
    f = frames(p, n=2, exposure_s=1.0, temperature_c=60.0, photon_flux=0.0, black_level_dn=0)
    assert f.mean() == pytest.approx(0.28 * 4000.0, rel=0.01)


def test_ob_columns_get_no_photo_charge():
    p = BASE.replace(ob_columns=6, read_noise_e=2.0)
    s = SimSensor(p, 2)
    f = s.render(4, exposure_s=0.01, photon_flux=1e6).astype(np.float64)
    assert abs(f[:, :, :6].mean() - 64) < 0.2
    assert f[:, :, 6:].mean() > 64 + 1000
    assert np.all(s.truth(exposure_s=0.01, photon_flux=1e6)["maps"]["q"][:, :6] == 0)


def test_dark_current_and_dsnu_double_every_8_c():
    p = BASE.replace(dark_current_e_per_s=2000.0, dsnu_e_per_s=400.0)
    s = SimSensor(p, 4)
    out = {}
    for temp in (52.0, 60.0, 68.0):
        kw = dict(exposure_s=0.5, temperature_c=temp, dark=True, black_level_dn=0)
        f = s.render(4, **kw).astype(np.float64)
        t = s.truth(**kw)
        out[temp] = (f.mean(), f.mean(axis=0).std(), t)
    for lo, hi in ((52.0, 60.0), (60.0, 68.0)):
        assert out[hi][2]["dark_current_e_per_s"] / out[lo][2]["dark_current_e_per_s"] == pytest.approx(2.0)
        assert out[hi][2]["dsnu_e_per_s"] / out[lo][2]["dsnu_e_per_s"] == pytest.approx(2.0)
        assert out[hi][0] / out[lo][0] == pytest.approx(2.0, rel=0.01)
        assert out[hi][1] / out[lo][1] == pytest.approx(2.0, rel=0.05)
    t60 = out[60.0][2]
    assert t60["dark_current_e_per_s"] == pytest.approx(2000.0)
    assert out[60.0][0] == pytest.approx(0.28 * 1000.0, rel=0.01)


def test_dark_shot_noise_is_poisson():
    p = BASE.replace(dark_current_e_per_s=400.0, conversion_gain_uv_per_e=250.0)  # G = 1 DN/e-
    kw = dict(exposure_s=1.0, temperature_c=60.0, dark=True, black_level_dn=0)
    f = frames(p, n=20, **kw)
    v = f.var(axis=0, ddof=1).mean()
    t = SimSensor(p, 3).truth(**kw)
    assert t["Pt"] == pytest.approx(400.0)
    assert abs(v - 400.0) < tol(400.0, p.rows * p.cols * 19)


def test_crosstalk_spreads_charge_to_neighbours():
    p = BASE.replace(crosstalk_pct=4.0, cfa="RGGB", cfa_response=(1.0, 0.0, 0.0, 0.0))
    f = frames(p, n=4, photon_flux=1e6, black_level_dn=0)
    lit = f[:, 2:-2:2, 2:-2:2].mean()
    side = f[:, 2:-2:2, 3:-2:2].mean()  # two lit neighbours (left, right)
    diag = f[:, 3:-2:2, 3:-2:2].mean()  # no lit 4-neighbour
    assert side / lit == pytest.approx(2 * 0.01 / 0.96, rel=0.05)
    assert diag < 1.0


def test_cfa_response_factors_per_phase():
    p = BASE.replace(cfa="GRBG", cfa_response=(1.0, 0.5, 0.25, 1.0))
    f = frames(p, n=2, photon_flux=1e6, black_level_dn=0)
    g = f[:, 0::2, 0::2].mean()
    assert f[:, 0::2, 1::2].mean() / g == pytest.approx(0.5, rel=0.01)
    assert f[:, 1::2, 0::2].mean() / g == pytest.approx(0.25, rel=0.01)


def test_photon_flux_map():
    p = BASE
    flux = np.zeros((p.rows, p.cols))
    flux[:, 32:] = 1e6
    f = frames(p, n=2, photon_flux=flux, black_level_dn=0)
    assert np.all(f[:, :, :32] == 0) and f[:, :, 32:].mean() == pytest.approx(0.28 * 6000, rel=0.01)


def test_image_lag():
    p = BASE.replace(lag_fraction=0.1)
    s = SimSensor(p, 1)
    kw = dict(exposure_s=0.01, black_level_dn=0)
    on = s.render(3, photon_flux=1e6, **kw).astype(np.float64).mean(axis=(1, 2))
    off = s.render(2, photon_flux=0.0, **kw).astype(np.float64).mean(axis=(1, 2))
    sig = 0.28 * 6000.0
    assert on[0] == pytest.approx(0.9 * sig, rel=5e-3)
    assert on[1] == pytest.approx(sig, rel=5e-3) and on[2] == pytest.approx(sig, rel=5e-3)
    assert off[0] == pytest.approx(0.1 * sig, rel=0.02)
    assert off[1] == 0


def test_same_seed_same_frames_different_seed_different_patterns():
    p = SensorParams(rows=48, cols=64)
    kw = dict(exposure_s=0.01, photon_flux=2e5)
    a, b = SimSensor(p, 7).render(3, **kw), SimSensor(p, 7).render(3, **kw)
    assert np.array_equal(a, b)
    c = SimSensor(p, 8)
    assert not np.array_equal(c.truth(**kw)["maps"]["Cs"], SimSensor(p, 7).truth(**kw)["maps"]["Cs"])
    assert not np.array_equal(c.render(3, **kw), a)
    # start_frame reproduces a frame regardless of what came before
    s = SimSensor(p, 7)
    s.render(5, **kw)
    assert np.array_equal(s.render(1, start_frame=1, **kw)[0], a[1])
    assert not np.array_equal(a[0], a[1])


def test_exact_mode_same_statistics_as_fast():
    p = BASE.replace(read_noise_e=5.0)
    for mode in ("exact", "gaussian"):
        f = frames(p, n=10, photon_flux=2e5, shot_noise=mode)
        v = f.var(axis=0, ddof=1).mean() - Q12
        expect = 0.28**2 * (25.0 + 1200.0)
        assert abs(v - expect) < tol(expect, p.rows * p.cols * 9)


def test_added_photocharge_and_flutter():
    p = BASE.replace(added_photocharge_e=1000.0)
    f = frames(p, n=4, black_level_dn=0)
    assert f.mean() == pytest.approx(280.0, rel=0.01)
    assert frames(p, n=2, dark=True, black_level_dn=0).max() == 0
    # flutter: frame means scatter by flutter_pct of the signal (a frame-global gain term)
    p = BASE.replace(flutter_pct=2.0)
    for mode in ("auto", "exact"):
        f = frames(p, n=100, photon_flux=1e6, black_level_dn=0, shot_noise=mode)
        m = f.mean(axis=(1, 2))
        rel = m.std(ddof=1) / m.mean()
        assert rel == pytest.approx(0.02, rel=4 * np.sqrt(1 / 198))


def test_pixel_fpn_mixture_gaussian_dsnu_plus_exponential_tail():
    s1, b = 100.0, 50.0  # DSNU sigma and exponential-tail mean, e-/s at 60 C
    p = BASE.replace(rows=96, cols=128, dark_current_e_per_s=1000.0, dsnu_e_per_s=s1, dark_tail_e_per_s=b)
    s = SimSensor(p, 8)
    t = s.truth(exposure_s=1.0, temperature_c=60.0, dark=True)
    G = t["G"]
    assert t["Ps"] == pytest.approx(G**2 * (s1**2 + b**2))
    n = p.rows * p.cols
    var = s1**2 + b**2
    mu4 = 3 * s1**4 + 6 * s1**2 * b**2 + 9 * b**4
    real = t["realized"]["Ps"] / G**2
    assert abs(real - var) < 4 * np.sqrt((mu4 - var**2) / n)
    dark = t["maps"]["dark_e_per_s"].ravel()
    skew = float(np.mean((dark - dark.mean()) ** 3) / dark.var() ** 1.5)
    assert skew == pytest.approx(2 * b**3 / var**1.5, abs=0.15)  # the exponential tail's skewness
    assert dark.mean() == pytest.approx(1000.0, abs=4 * np.sqrt(var / n))
    # the frames carry it: time-averaged dark image vs truth map
    f = s.render(8, exposure_s=1.0, temperature_c=60.0, dark=True, black_level_dn=0).astype(np.float64).mean(0)
    resid = f - G * t["maps"]["dark_e_per_s"]
    assert abs(resid.mean()) < 0.1 and resid.std() < np.sqrt(G**2 * 1000.0 / 8 + 1 / 12) * 1.1


def test_column_and_row_gain_non_uniformity_realized():
    p = BASE.replace(rows=96, cols=128, col_gain_pct=2.0, row_gain_pct=1.0)
    t = SimSensor(p, 9).truth(exposure_s=0.01)
    assert t["Cg"] == pytest.approx(4e-4) and t["Rg"] == pytest.approx(1e-4)
    assert abs(t["realized"]["Cg"] - 4e-4) < tol(4e-4, p.cols - 1)
    assert abs(t["realized"]["Rg"] - 1e-4) < tol(1e-4, p.rows - 1)
    # the realized maps are scaled to mean 1: the array's mean conversion gain is G itself
    # (drawn unscaled, the mean of 128 columns at 2 % departs by ~2e-3: this can fail)
    m = t["maps"]
    assert abs(m["Cg"].mean() - 1) < 1e-6 and abs(m["Rg"].mean() - 1) < 1e-6
    assert m["gain_dn_per_e"].mean() / t["G"] == pytest.approx(1.0, abs=1e-6)
