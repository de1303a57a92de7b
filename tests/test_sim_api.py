"""SimSensor API: argument errors, truth keys, mixed exact/Gaussian maps, output range."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ares.errors import InputError
from ares.sim import SensorParams, SimSensor

P = SensorParams(rows=48, cols=64)


@pytest.mark.parametrize(
    "kw, words",
    [
        (dict(shot_noise="fancy"), "shot_noise"),
        (dict(photon_flux=np.ones((10, 10))), "shape"),
        (dict(photon_flux=-1.0), "photon_flux"),
        (dict(photon_flux=np.ones((2, 48, 64))), "photon_flux"),
        (dict(exposure_s=-0.1), "exposure_s"),
        (dict(analog_gain=0.0), "analog_gain"),
        (dict(temperature_c="hot"), "temperature_c"),
        (dict(photon_flux="bright"), "photon_flux"),
    ],
)
def test_bad_render_arguments_raise_one_sentence(kw, words):
    s = SimSensor(P, 0)
    with pytest.raises(InputError, match=words) as e:
        s.render(1, **{"exposure_s": 0.01, **kw})
    assert "\n" not in str(e.value)


def test_bad_frame_count_and_params_type():
    with pytest.raises(InputError, match="number of frames"):
        SimSensor(P, 0).render(-1, exposure_s=0.01)
    with pytest.raises(InputError, match="SensorParams"):
        SimSensor({"rows": 4}, 0)
    assert SimSensor(P, 0).render(0, exposure_s=0.01).shape == (0, 48, 64)


def test_truth_has_every_documented_key():
    t = SimSensor(P, 0).truth(exposure_s=0.01, photon_flux=1e5, temperature_c=40.0, analog_gain=2.0,
                              black_level_dn=100)
    for k in ("o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global", "G", "Cg", "Rg", "Pg", "q", "delta",
              "quantization_dn2", "dark_current_e_per_s", "dsnu_e_per_s", "full_well_e", "full_well_dn",
              "read_noise_e", "lag_fraction", "adc", "defects", "maps", "realized", "scene"):
        assert k in t, k
    for k in ("o", "Cs", "Rs", "Ps", "Cg", "Rg", "Pg", "Pt"):
        assert np.isfinite(t["realized"][k])
    for k in ("hot", "warm", "dead", "stuck", "noisy", "rts"):
        r, c = t["defects"][k]
        assert r.shape == c.shape
    assert t["G"] == pytest.approx(P.gain_dn_per_e(2.0))
    assert t["q"] == pytest.approx(1e5 * 0.01 * P.qe)
    assert t["delta"] == t["q"]
    assert t["dark_current_e_per_s"] == pytest.approx(P.dark_current_e_per_s * 2 ** (-20 / 8))
    assert t["maps"]["Cs"].shape == (64,) and t["maps"]["Ps"].shape == (48, 64)


def test_auto_mode_mixes_exact_and_gaussian_on_a_map():
    p = SensorParams(rows=48, cols=64, conversion_gain_uv_per_e=250.0, qe=1.0).noiseless()
    flux = np.full((48, 64), 1.0)
    flux[:, 32:] = 3000.0
    f = SimSensor(p, 0).render(8, exposure_s=1.0, photon_flux=flux, black_level_dn=64).astype(np.float64) - 64
    low, high = f[:, :, :32].ravel(), f[:, :, 32:].ravel()
    n = low.size
    assert abs(low.mean() - 1) < 4 * np.sqrt(1 / n) and abs(low.var() - 1) < 4 * np.sqrt(3 / n)
    assert np.mean(low == 0) == pytest.approx(np.exp(-1), abs=4 * np.sqrt(0.23 / n))
    assert abs(high.mean() - 3000) < 4 * np.sqrt(3000 / n)
    assert abs(high.var() - 3000) < 4 * np.sqrt(2 / n) * 3000


@settings(max_examples=15, deadline=None)
@given(
    bits=st.integers(8, 14),
    gain=st.floats(1.0, 16.0),
    flux=st.floats(0.0, 1e8),
    black=st.floats(-100, 5000),
    mode=st.sampled_from(["auto", "exact", "gaussian"]),
    seed=st.integers(0, 2**31),
)
def test_output_is_always_a_valid_code(bits, gain, flux, black, mode, seed):
    p = SensorParams(rows=8, cols=10, adc_bits=bits, lag_fraction=0.05, adc_dnl_lsb=0.1)
    f = SimSensor(p, seed).render(2, exposure_s=0.01, photon_flux=flux, analog_gain=gain,
                                  black_level_dn=black, shot_noise=mode)
    assert f.dtype == np.uint16 and f.shape == (2, 8, 10)
    assert f.max() <= p.max_code


def test_truth_q_by_bayer_phase():
    p = SensorParams(rows=48, cols=64, cfa="RGGB", cfa_response=(0.5, 1.0, 1.0, 0.25), crosstalk_pct=0.0)
    t = SimSensor(p, 0).truth(exposure_s=0.01, photon_flux=1e5)
    assert t["q_by_phase"] == pytest.approx([300.0, 600.0, 600.0, 150.0])


def test_bad_start_frame_and_ramp_count():
    s = SimSensor(P, 0)
    with pytest.raises(InputError, match="start_frame"):
        s.render(1, exposure_s=0.01, start_frame=-3)
    with pytest.raises(InputError, match="number of frames"):
        s.render_ramp(2.5)


def test_a_new_operating_point_is_planned_after_the_previous_ones_maps_are_dropped(monkeypatch):
    """The simulator's per-point maps (offsets, sigmas, gain maps: ~200-300 MiB at 4096x3072)
    are released before the next point's are made, not after: the peak of emva_4.xml at
    4096x3072 was two points' maps at once (the short scan of benchmarks/estimates.md: 1960 MiB,
    1714-1744 after; the full one 1.82 GiB, benchmarks/twelve_mp.md).
    The frames are the same either way (the cache only saves the work)."""
    s = SimSensor(SensorParams(rows=24, cols=32), 3)
    seen = []
    plan = SimSensor._plan

    def spy(self, sc):
        seen.append(self._cache)
        return plan(self, sc)

    monkeypatch.setattr(SimSensor, "_plan", spy)
    a = s.render(2, exposure_s=0.01, photon_flux=1e4, start_frame=0)
    s.render(2, exposure_s=0.02, photon_flux=1e4)
    assert np.array_equal(s.render(2, exposure_s=0.01, photon_flux=1e4, start_frame=0), a)
    assert len(seen) == 3 and all(c is None for c in seen)
