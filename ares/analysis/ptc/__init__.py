"""Photon transfer and what follows from it: per-level statistics, gain fits and the headline
choice, saturation and turnoff, read noise, dark current against exposure and temperature,
lag, ADC linearity, pixel vs chain noise. Imports ``kernels``, ``stats``, ``spatial``,
``noise``."""
