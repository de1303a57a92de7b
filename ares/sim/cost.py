"""What a simulated frame costs to compute, relative to other frames of the same sensor,
by the path the simulator takes for it -- for the time remaining (``ares.scan.eta``),
which measures seconds per frame and needs only how the stages to come compare with the
ones it has timed.

The simulator's frame time follows its path, not the exposure: in make run's scan a frame
whose photo charge is drawn exactly (alias method, below ~300 e-) took 5.2 ms of the
simulator's time, one drawn from the normal table 3.4 ms, a dark frame 2.4 ms. The
constants are those times split by what each path draws (ms for a VGA frame, measured
in the scan, beside the stage analysis of the thread next to it: alone the normal-table
draws cost ~20 % less, the alias draws the same). Only the ratios are used: the time
remaining measures the simulator's own seconds per unit of cost as the scan runs.
"""

from __future__ import annotations

from ares.sim import fused

FAST = 1.2  # one normal draw a pixel for every temporal term (SimSensor's fast path)
BASE = 0.85  # the general path's read noise, offsets and full-well clip, with no charge drawn
DRAW = {fused.NONE: 0.0, fused.GAUSS: 0.95, fused.ALIAS: 2.75}  # + a charge drawn this way
MAP = 12.0  # + a charge drawn exactly per pixel (a unit-rate arrival count; grows with the mean)
LOOKUP = 0.65  # + an ADC with INL/DNL (a code table searched per pixel)
RAMP = 0.5  # an ADC ramp test pattern


def frame_cost(fast: bool, modes: tuple[int | None, int | None], lookup: bool) -> float:
    """Relative cost of a frame: ``fast`` (SimSensor's one-draw path), else the photo and
    dark charges' ``fused`` modes (None: drawn on the numpy path per pixel); ``lookup``: an
    ADC with a code table."""
    cost = FAST if fast else BASE + sum(MAP if m is None else DRAW[m] for m in modes)
    return cost + (LOOKUP if lookup else 0.0)
