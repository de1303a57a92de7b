"""The simulator's expected image (``ares.sim.expected``: the truth of EMVA 1288 4.0 Linear
Section 8's DSNU1288/PRNU1288 in ``benchmarks/bench_truth_z.py``) against the mean of many
rendered frames: every pixel's mean within its own SE (z SD ~1), through a bowed, uneven ADC
(INL 2 LSB, DNL 0.3), dark and lit, with stuck, noisy, hot and telegraph pixels."""

import numpy as np
import pytest

from ares.sim import SensorParams, SimSensor
from ares.sim.expected import expected_codes


@pytest.mark.parametrize("flux", [0.0, 2e5])
def test_expected_image_is_the_mean_of_the_frames(flux):
    p = SensorParams(rows=40, cols=48, adc_inl_lsb=2.0, adc_dnl_lsb=0.3, stuck_rate_ppm=2000, noisy_rate_ppm=5000,
                     hot_rate_ppm=5000, rts_rate_ppm=5000, frame_global_dn=0.0)
    s = SimSensor(p, seed=3)
    kw = dict(exposure_s=0.01, photon_flux=flux)
    e = expected_codes(s, **kw)
    n = 600
    fr = s.render(n, **kw).astype(np.float64)
    m, v = fr.mean(0), fr.var(0, ddof=1)
    rts = np.zeros(s.shape, bool)
    rts.ravel()[s.patterns.defects.index["rts"]] = True
    stuck = np.zeros(s.shape, bool)
    stuck.ravel()[s.patterns.defects.index["stuck"]] = True
    assert stuck.any() and rts.any()
    assert np.array_equal(m[stuck], e[stuck])
    ok = ~rts & ~stuck
    z = (m - e)[ok] / np.sqrt(v[ok] / n)
    assert abs(z.mean()) < 0.3 and 0.9 < z.std() < 1.1 and np.abs(z).max() < 5, (z.mean(), z.std())
    # the test can fail: with an ideal quantizer in place of the ADC's levels the means are off
    adc = s.patterns.adc
    levels, adc.thresholds = adc.thresholds, None
    try:
        z0 = (m - expected_codes(s, **kw))[ok] / np.sqrt(v[ok] / n)
    finally:
        adc.thresholds = levels
    assert np.abs(z0).max() > 10, np.abs(z0).max()
