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
NUMPY = 1.5  # the general path without the fused kernel (measured 1.35-1.55x on dark, Gaussian and alias frames)
EXACT = 14.0  # + numpy's Poisson draw for every pixel (46 ns a pixel); a map draws it only where it must
LOOKUP = 0.65  # + an ADC with INL/DNL (a code table searched per pixel)
RAMP = 4.2  # an ADC ramp test pattern (float64 levels through the ADC: 2.3x a dark frame) ...
RAMP_LOOKUP = 5.2  # ... + its code table lookup (float64: numpy's, not the fused one; 3.8x a dark frame in all)


def frame_cost(fast: bool, modes: tuple[int | None, int | None], lookup: bool, numpy_path: bool = False,
               exact: float = 0.0) -> float:
    """Relative cost of a frame: ``fast`` (SimSensor's one-draw path), else the photo and
    dark charges' ``fused`` modes (None: drawn per pixel on the numpy path, a normal draw
    everywhere and numpy's Poisson on the fraction ``exact`` of the pixels, summed over
    both charges); ``numpy_path``: the fused kernel does not apply; ``lookup``: an ADC with
    a code table."""
    if fast:
        cost = FAST
    else:
        cost = BASE + sum(DRAW[fused.GAUSS if m is None else m] for m in modes)
        cost = cost * NUMPY if numpy_path else cost
        cost += EXACT * exact
    return cost + (LOOKUP if lookup else 0.0)


def ramp_cost(lookup: bool) -> float:
    """Relative cost of an ADC ramp frame (test_mode 2), ``lookup``: an ADC with a code table."""
    return RAMP + (RAMP_LOOKUP if lookup else 0.0)
