"""Photon-counting histogram (ares.analysis.optics.photon_counting, Starkey & Fossum 2016) against
the simulator's truth: a deep sub-electron sensor (K = 10 DN/e-, no fixed-pattern noise,
exact Poisson photo-charge) at 0.15-0.45 e- read noise, 5 seeds each (slow), and one cheap
fixed-seed check of the SEs' spread/SE ratio at 0.45 e-. The gain's SE grows
with the read noise (0.5 % at 0.45 e- for 64x64x20 values): the 0.5 % target needs ~8x that
(128x128x40), used for every level here."""

import numpy as np
import pytest

from ares.analysis.optics.photon_counting import fit_histogram, photon_transfer
from ares.sim.params import SensorParams
from ares.sim.sensor import SimSensor

H_E = 1.5  # mean photo-electrons per pixel
FLUX = H_E / (0.01 * 0.6)


def _stacks(rn, seed, frames=20, size=64):
    p = SensorParams(rows=size, cols=size, conversion_gain_uv_per_e=70.0, adc_lsb_uv=7.0).noiseless()
    s = SimSensor(p.replace(read_noise_e=rn), seed=seed)
    light = s.render(frames, exposure_s=0.01, photon_flux=FLUX, black_level_dn=100, shot_noise="exact")
    dark = s.render(frames, exposure_s=0.01, dark=True, black_level_dn=100)
    return s.truth(exposure_s=0.01, photon_flux=FLUX, black_level_dn=100), light, dark


@pytest.mark.slow
@pytest.mark.parametrize("rn", [0.15, 0.3, 0.45])
def test_gain_and_read_noise_against_truth_over_5_seeds(rn):
    for seed in range(5):
        t, light, _ = _stacks(rn, seed, frames=40, size=128)
        r = fit_histogram(light)
        K, s = r["K"], r["read_noise_e"]
        assert abs(K.value / t["G"] - 1) < 0.005, (seed, K)
        assert abs(s.value / t["read_noise_e"] - 1) < 0.03, (seed, s)
        assert abs(K.value - t["G"]) < 4 * K.se and abs(s.value - t["read_noise_e"]) < 4 * s.se
        assert abs(r["mean_e"].value - float(np.mean(t["maps"]["q"]))) < 4 * r["mean_e"].se + 0.01


def test_spread_over_se_at_045_e_fixed_seeds():
    """The SEs say how far the estimates scatter: at 0.45 e- (the peaks overlapping most) the
    spread of K and read noise over 10 fixed seeds (64x64x20 values each) over the mean SE.
    A ratio from 10 seeds is itself uncertain by ~24 % (these seeds happen to give K 1.42, read
    noise 1.50; 200 seeds of the same size give 1.00 and 0.99); the band 0.5-1.8 fails an SE off
    by a factor 2 either way. The 0.7-1.3 target is the benchmark's (60-300 seeds of
    128x128x40 values, benchmarks/beyond_linear.md)."""
    k, s = [], []
    for seed in range(10):
        t, light, _ = _stacks(0.45, 300 + seed)
        r = fit_histogram(light)
        k.append((r["K"].value / t["G"] - 1, r["K"].se / t["G"]))
        s.append((r["read_noise_e"].value / 0.45 - 1, r["read_noise_e"].se / 0.45))
    for name, a in (("K", np.array(k)), ("read noise", np.array(s))):
        ratio = a[:, 0].std(ddof=1) / a[:, 1].mean()
        assert 0.5 < ratio < 1.8, (name, ratio)
        assert abs(a[:, 0].mean()) < 3 * a[:, 1].mean() / np.sqrt(len(a)) + 1e-4, name  # no bias beyond the SE


def test_photon_transfer_beside_it():
    t, light, dark = _stacks(0.3, 0)
    pt = photon_transfer(light, dark)
    assert abs(pt["K"].value - t["G"]) < 4 * pt["K"].se
    assert fit_histogram(light)["K"].se < pt["K"].se / 2  # the histogram does better here


def test_not_available_above_the_limit():
    _, light, _ = _stacks(0.8, 1)
    r = fit_histogram(light)
    assert not r["K"].available and "too high for separated peaks" in r["K"].note and "0.5 e-" in r["K"].note
    assert "at least 1000" in fit_histogram(light[0, :10, :10])["K"].note
