"""Photon transfer on a small local synthetic sensor (hand-checked truth)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from ares.analysis.ptc.levels import pair_stats, stack_stats
from ares.analysis.ptc.photon_transfer import analyze_ptc, loglog_slopes
from ares.analysis.ptc.fit import astier_fit, astier_model, origin_fit, wls_line


def synth_pair(rng, n_e, shape, K=0.25, read_e=3.0, fw=16000.0, prnu=0.01, offset=100.0, bits=12,
               gain_map=None):
    g = gain_map if gain_map is not None else 1.0
    out = []
    for _ in range(2):
        q = rng.poisson(n_e * g, shape).astype(float)
        q = np.minimum(q, fw)
        v = K * (q + rng.normal(0, read_e, shape)) + offset
        out.append(np.clip(np.round(v), 0, (1 << bits) - 1).astype(np.uint16))
    return np.stack(out)


def make_ptc(seed=1, shape=(128, 128), levels=None, **kw):
    rng = np.random.default_rng(seed)
    gm = 1 + 0.01 * rng.standard_normal(shape)
    levels = np.geomspace(30, 24000, 28) if levels is None else levels
    bits = kw.get("bits", 12)
    dark = [pair_stats(*synth_pair(rng, 0.0, shape, gain_map=gm, **kw), max_code=(1 << bits) - 1)
            for _ in levels]
    bright = [pair_stats(*synth_pair(rng, n, shape, gain_map=gm, **kw), max_code=(1 << bits) - 1)
              for n in levels]
    return bright, dark, np.asarray(levels)


def test_pair_formula_removes_offset_change():
    rng = np.random.default_rng(0)
    a = rng.normal(1000, 5, (200, 200))
    b = rng.normal(1000, 5, (200, 200)) + 3.0  # offset jump between frames
    s4 = pair_stats(a, b)
    s3 = pair_stats(a, b, offset_correction=False)
    assert s4.var == pytest.approx(25, rel=0.02)
    assert s3.var == pytest.approx(25 + 4.5, rel=0.02)
    st = stack_stats(np.stack([a, b, a + 1, b - 1]))
    assert st.var > 0 and st.n_frames == 4


def test_fits_recover_line_and_astier_reduces_to_line():
    s = np.linspace(100, 3000, 20)
    v = 0.25 * s + 2.0
    lf = wls_line(s, v, 1e5)
    assert lf.slope == pytest.approx(0.25, rel=1e-9) and lf.intercept == pytest.approx(2.0, rel=1e-6)
    assert origin_fit(s, 0.25 * s).slope == pytest.approx(0.25)
    af = astier_fit(s, v, 1e5)
    assert af.gain_dn_per_e == pytest.approx(0.25, rel=1e-6) and abs(af.a00) < 1e-9
    # brighter-fatter curvature
    vb = astier_model(s, 2e-6, 4.0, 10.0)
    af = astier_fit(s, vb, 1e6)
    assert af.gain_e_per_dn == pytest.approx(4.0, rel=1e-4) and af.a00 == pytest.approx(2e-6, rel=1e-3)


def test_ptc_gain_read_noise_full_well_and_exclusions():
    bright, dark, ne = make_ptc()
    r = analyze_ptc(bright, dark, photons=ne)
    K = 0.25
    for e in (r.gain_dn_per_e, r.gain_origin_dn_per_e):
        assert abs(e.value - K) < 4 * e.se and abs(e.value / K - 1) < 0.01
    assert r.read_noise_e.value == pytest.approx(3.0, rel=0.03)
    assert r.conversion_gain_uv_per_e.available is False
    # levels above the 16000 e- full well are excluded, each with a reason
    ex = dict(r.excluded())
    assert ex and all(ex.values())
    assert all(ne[i] > 13000 for i in ex)
    assert r.full_well_e["max_variance"].value == pytest.approx(16000, rel=0.1)
    for name in ("max_variance", "max_code", "plateau", "linearity_1pct"):
        assert name in r.full_well_e and r.full_well_e[name].note
    assert "ptc_turnoff" not in r.full_well_e and r.turnoff_e.note  # one turnoff figure (issue 34)
    assert set(r.gain_vs_range) == {"0-30%", "0-50%", "0-70%"}
    assert r.noise_model["prnu_pct"].value == pytest.approx(1.0, rel=0.2)
    assert r.dynamic_range_db.available and r.sensitivity_threshold_e.available


def test_degenerate_inputs_give_verdicts_not_exceptions():
    """Through the API (no table bounds): a variance whose square overflows float64
    excludes its level with the reason; weights that single out one level leave the line
    fit not available instead of raising; photon counts that are all 0 give QE n/a."""
    from dataclasses import replace

    bright, dark, ne = make_ptc(shape=(32, 32), levels=np.geomspace(50, 8000, 12))
    bright = list(bright)
    bright[4] = replace(bright[4], var=1e200)
    r = analyze_ptc(bright, dark, photons=ne)
    st = {lv.index: (lv.status, lv.reason) for lv in r.levels}
    assert st[4][0] == "excluded" and "its square overflows" in st[4][1]
    assert abs(r.gain_dn_per_e.value - 0.25) < 4 * r.gain_dn_per_e.se
    s = np.linspace(100, 1000, 6)
    v = 0.25 * s + np.r_[0, 1, -1, 2, 0, 1]
    for v_se in (np.r_[1e-300, np.ones(5)], np.r_[1.0, np.full(5, 1e30)]):  # one level outweighs the rest
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            lf = wls_line(s, v, 1e4, v_se=v_se)  # (was: a slope without SE; LinAlgError)
        assert math.isnan(lf.slope) or math.isfinite(lf.slope_se)  # never a slope without its SE
    r0 = analyze_ptc(make_ptc(shape=(32, 32), levels=np.geomspace(50, 8000, 12))[0], dark, photons=np.zeros(12))
    assert not r0.qe.available and "does not rise with the photon counts" in r0.qe.note


def test_clipped_and_nonmonotonic_levels_are_excluded_with_reason():
    ne = np.array([100, 300, 600, 1000, 1500, 2000, 2600, 3200, 4000, 4800, 5600, 6400, 7000, 7750, 8200.0])
    bright, dark, _ = make_ptc(levels=ne, shape=(64, 64), bits=11, fw=1e6)  # ADC clips near 7800 e-
    # a light-source glitch: level 6 gets the illumination of level 2
    rng = np.random.default_rng(5)
    bright[6] = pair_stats(*synth_pair(rng, 600.0, (64, 64), bits=11, fw=1e6), max_code=2047)
    r = analyze_ptc(bright, dark, photons=ne)
    st = {lv.index: (lv.status, lv.reason) for lv in r.levels}
    assert st[6][0] == "excluded" and st[6][1].startswith("non-monotonic")
    clipped = [i for i, (s, why) in st.items() if why.startswith("clipped")]
    assert clipped and all(ne[i] >= 7700 for i in clipped)
    assert all(lv.status != "fit" or not lv.reason for lv in r.levels)
    assert 6 not in [lv.index for lv in r.used("fit")]
    assert r.gain_dn_per_e.value == pytest.approx(0.25, rel=0.02)


def test_read_noise_upper_limit_when_quantization_dominates():
    rng = np.random.default_rng(3)
    shape = (64, 64)
    dark = [pair_stats(*synth_pair(rng, 0.0, shape, read_e=0.5, K=0.5)) for _ in range(6)]
    bright = [pair_stats(*synth_pair(rng, n, shape, read_e=0.5, K=0.5)) for n in (200, 400, 800, 1600, 2400, 3200)]
    r = analyze_ptc(bright, dark)
    assert r.read_noise_is_upper_limit
    assert "upper limit" in r.read_noise_e.note and not math.isfinite(r.read_noise_e.se)


def test_conversion_gain_units_and_zones():
    bright, dark, ne = make_ptc(shape=(64, 64))
    r = analyze_ptc(bright, dark, photons=ne, adc_lsb_uv=250.0, analog_gain=2.0)
    assert r.conversion_gain_uv_per_e.value == pytest.approx(r.gain_dn_per_e.value * 125.0)
    assert r.gain_e_per_dn.value == pytest.approx(1 / r.gain_dn_per_e.value)
    good = r.used("fit") + r.used("valid")
    sig = np.array([lv.signal for lv in good])
    noise = np.sqrt([lv.variance for lv in good])
    slopes = loglog_slopes(sig, noise)
    assert slopes[len(slopes) // 2] == pytest.approx(0.5, abs=0.1)
    assert r.zones["read_to_shot_e"].value == pytest.approx(r.noise_model["sensor_noise_e"].value ** 2)


@pytest.mark.parametrize("seed,a00", [(1, 0.0), (2, 1.5e-6), (3, 4e-6), (4, -5e-7)])
def test_astier_fit_equals_scipy_curve_fit(seed, a00):
    """ARES's Levenberg-Marquardt (no scipy.optimize import) against curve_fit with the same
    weights on noisy photon-transfer data: the same parameters to MINPACK's tolerance and
    the same standard errors."""
    from scipy.optimize import curve_fit

    from ares.analysis.ptc.fit import astier_fit

    rng = np.random.default_rng(seed)
    s = np.geomspace(30, 3500, 24)
    dof = 2e5
    truth = astier_model(s, a00, 3.6, 25.0)
    sig = np.sqrt(2.0 / dof) * truth
    v = truth + sig * rng.standard_normal(s.size)
    af = astier_fit(s, v, dof)
    lf = wls_line(s, v, dof, v_se=np.sqrt(2.0 / dof) * np.abs(v))
    g0 = 1.0 / lf.slope
    ref, cov = curve_fit(astier_model, s, v, p0=[0.0, g0, lf.intercept * g0 * g0],
                         sigma=np.sqrt(2.0 / dof) * np.abs(v), absolute_sigma=True, maxfev=20000)
    r = (v - astier_model(s, *ref)) / (np.sqrt(2.0 / dof) * np.abs(v))
    se = np.sqrt(np.diag(cov * max(float(r @ r) / (s.size - 3), 1.0)))
    assert af.gain_e_per_dn == pytest.approx(ref[1], rel=1e-7)
    assert af.a00 == pytest.approx(ref[0], rel=1e-4, abs=1e-6 * se[0])
    assert af.n00 == pytest.approx(ref[2], rel=1e-6, abs=1e-4 * se[2])
    for mine, theirs in ((af.gain_se, se[1]), (af.a00_se, se[0]), (af.n00_se, se[2])):
        assert mine == pytest.approx(theirs, rel=1e-4)
    assert abs(af.gain_e_per_dn - 3.6) < 5 * af.gain_se  # and both find the truth


def test_bspline_design_equals_scipy():
    """The Cox - de Boor design matrix of the Eq. 51 regression (and of its derivative)
    against scipy.interpolate.BSpline on clamped knots at signal quantiles, both ends included."""
    from scipy.interpolate import BSpline

    from ares.analysis.ptc.fit import bspline_design

    rng = np.random.default_rng(5)
    for inner in ([], [700.0], [400.0, 1200.0, 2500.0]):
        s = np.r_[10.0, np.sort(rng.uniform(10, 3000, 30)), 3000.0]
        t = np.r_[[s[0]] * 4, inner, [s[-1]] * 4]
        nb = t.size - 4
        np.testing.assert_allclose(bspline_design(s, t), BSpline.design_matrix(s, t, 3).toarray(), atol=1e-14)
        ref = np.array([BSpline(t, np.eye(nb)[j], 3).derivative()(s) for j in range(nb)]).T
        np.testing.assert_allclose(bspline_design(s, t, derivative=True), ref, rtol=1e-10, atol=1e-18)


def test_astier_fit_on_two_distinct_levels_is_not_available_rather_than_a_value_without_se():
    """Five levels at only two signals cannot determine three parameters: J^T J is singular
    to rounding and its inverse has a negative variance. The fit is then all NaN (no
    gain without its SE), the model choice says why, and nothing warns."""
    import warnings

    from ares.analysis.ptc.fit import astier_fit, choose_gain_model

    s = np.array([100.0, 100, 200, 200, 200])
    v = np.array([30.0, 30.5, 58, 58.4, 58.2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        af = astier_fit(s, v, 100)
        gm = choose_gain_model(s, v, 100)
    assert np.isnan(af.gain_e_per_dn) and np.isnan(af.gain_se) and af.n == 5
    assert gm.chosen == "linear" and "not determined by these levels" in gm.reason
