"""The simulated sensor's black level drifting on the bench's clock (``SensorParams``
``offset_warmup_dn``, ``offset_warmup_tau_s``, ``offset_drift_dn_per_s``; all off by default).

A real sensor's offset is not constant after power-up: the die warms by its own dissipation
and the clamp and the column amplifiers' offsets follow it, approaching the warm die's value
with the die's thermal time constant; on top, a slow drift (the chamber's regulation cycling,
the reference voltages ageing over hours). Here::

    offset(t) = A * (1 - exp(-t / tau)) + r * t        DN at the ADC input

with ``t`` the bench clock since power-up (the bench opened: ``SimClock`` 0). A frame's
offset is the one at its readout -- correlated double sampling takes the reset and signal
levels then -- i.e. at its exposure's end (``SimFrameSource`` stamps a frame at its start). The
die's temperature for the dark current is the chamber's (the warm-up's few tenths of a kelvin
on the dark current are not modelled): only the offset moves, as a black level does. Imports: nothing of ARES."""

from __future__ import annotations

import math


def drifts(params) -> bool:
    """Whether the sensor's offset moves with time at all."""
    return params.offset_warmup_dn != 0 or params.offset_drift_dn_per_s != 0


def offset_dn(params, t_s: float) -> float:
    """The black level's departure from its power-up value at bench time ``t_s`` (DN at the ADC
    input; 0 before power-up): the truth a drift analysis is checked against."""
    t = max(float(t_s), 0.0)
    return params.offset_warmup_dn * -math.expm1(-t / params.offset_warmup_tau_s) + params.offset_drift_dn_per_s * t


def rate_dn_per_s(params, t_s: float) -> float:
    """Its rate of change at ``t_s`` (DN/s): what a stack's frame means trend by then."""
    t = max(float(t_s), 0.0)
    return params.offset_warmup_dn / params.offset_warmup_tau_s * math.exp(-t / params.offset_warmup_tau_s) + \
        params.offset_drift_dn_per_s
