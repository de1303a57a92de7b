"""ARTEMIS-style Monte Carlo image sensor and the simulated bench around it.

Public API::

    SensorParams                  all model parameters (frozen, validated)
    SimSensor(params, seed)       .render(n, exposure_s=, photon_flux=, temperature_c=,
                                  analog_gain=, black_level_dn=, dark=, shot_noise=,
                                  start_frame=) -> uint16 (n, rows, cols);
                                  .render_ramp(n); .truth(...) -> dict (see ares.sim.truth)
    make_sim_bench(params, seed, faults) -> ares.hardware.interfaces.Bench
    SimRegisterBus, SimFrameSource, SimLightSource, SimChamber

May import ``hardware`` (the interfaces it implements), ``analysis`` (kernels; the Fe-55 electron yield) and the base modules."""

from ares.sim.bench import SimChamber, SimFrameSource, SimLightSource, SimRegisterBus, make_sim_bench
from ares.sim.params import SensorParams
from ares.sim.sensor import SimSensor

__all__ = ["SensorParams", "SimSensor", "make_sim_bench", "SimRegisterBus", "SimFrameSource",
           "SimLightSource", "SimChamber"]
