"""A Release 4.0 Linear measurement set recorded on the simulated sensor through the same
per-step and stack functions ``ares emva`` uses (``pair_step``, ``stack_moments``), with the
simulator's truth. Small (120 x 160) and defect-free so twenty seeds take seconds."""

from __future__ import annotations

import numpy as np

from ares.analysis.emva.sheet import EmvaInput, StackImage
from ares.analysis.ptc.levels import pair_step
from ares.analysis.ptc.levels import stack_moments
from ares.sim import SensorParams, SimSensor

CLEAN = dict(rows=120, cols=160, hot_rate_ppm=0.0, warm_rate_ppm=0.0, rts_rate_ppm=0.0, dead_rate_ppm=0.0,
             stuck_rate_ppm=0.0, noisy_rate_ppm=0.0, crosstalk_pct=0.0, adc_offset_dn=(0.0, 0.0),
             lag_fraction=0.0, dark_tail_e_per_s=0.0)
FLUX = 1e6  # photons / pixel / s
GAIN = 1.5  # analog gain: the ADC clips (4095) before the 12 ke- full well


def simulate(seed: int, L: int = 100, flux_map=None, **params):
    """(EmvaInput, truth at the shortest exposure, the SimSensor). Method I: exposure varied
    at constant irradiance, 50 steps to ~93 % of saturation and fine steps through it;
    L-frame dark and ~50 % stacks; 8 long dark exposures for the dark current."""
    p = SensorParams(**{**CLEAN, **params})
    s = SimSensor(p, seed=seed)
    t_sat = 9600 / p.qe / FLUX
    texp = np.r_[np.linspace(2e-4, 0.93 * t_sat, 50), np.arange(0.94 * t_sat, 1.03 * t_sat, 0.0025 * t_sat)]
    flux = FLUX if flux_map is None else flux_map
    bright, dark, steps = [], [], []
    for t in texp:
        a = s.render(2, exposure_s=t, photon_flux=flux, analog_gain=GAIN)
        d = s.render(2, exposure_s=t, dark=True, analog_gain=GAIN)
        sb, sd = pair_step(a[0], a[1], p.max_code), pair_step(d[0], d[1], p.max_code)
        bright.append(sb[1])
        dark.append(sd[1])
        steps.append((sb[2], sd[2]))
    t50 = 0.5 * t_sat
    stb, img_b, line_b, _ = stack_moments(s.render(L, exposure_s=t50, photon_flux=flux, analog_gain=GAIN))
    std, img_d, line_d, _ = stack_moments(s.render(L, exposure_s=t50, dark=True, analog_gain=GAIN))
    tdc = np.linspace(0.1, 0.8, 8)
    dm, dv = [], []
    for t in tdc:
        d = s.render(2, exposure_s=t, dark=True, analog_gain=GAIN)
        st = pair_step(d[0], d[1], p.max_code)[1]
        dm.append(st.mean)
        dv.append(st.var)
    inp = EmvaInput(texp * FLUX, texp, bright, dark, steps, None,
                    StackImage(img_d, std.s2_temporal, L, 0.0, t50, line_d),
                    StackImage(img_b, stb.s2_temporal, L, FLUX * t50, t50, line_b),
                    (tdc, np.array(dm), np.array(dv)), pixel_area_um2=p.pixel_pitch_um**2)
    return inp, s.truth(exposure_s=texp[0], photon_flux=FLUX, analog_gain=GAIN), s
