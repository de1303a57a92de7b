"""Physical ranges of the simulator's inputs: what a scan may ask of the simulated sensor.

The register fields bound exposure and analog gain (their ``min``/``max`` in the system
file, checked by the scan loader); these are the ranges no register holds:

- temperature: -40 to 125 C, the automotive grade's operating range (AEC-Q100 grade 0
  reaches 150 C, no image sensor is specified there); the dark-current model
  (``SensorParams.dark_scale``, doubling every ``dark_doubling_c``) is an extrapolation
  beyond it;
- light: at most 1000 full wells per (QE x 1 us) in photons/pixel/s: even the shortest
  exposure a register allows (1 us on the shipped map) then clips a thousand times over;
  above it the Poisson and Gaussian draws lose their meaning (1e30 photons/pixel/s overflows
  the charge arithmetic);
- array size: at most ``MAX_PIXELS`` pixels and ``MAX_SIDE`` per side (a 200000x200000
  simulated sensor is 40 Gpx: 80 GB a frame).

Each check returns the one sentence (without the file:line, which the caller knows) or None.
"""

from __future__ import annotations

TEMPERATURE_C = (-40.0, 125.0)
LIGHT_FULL_WELLS = 1000.0  # full wells per (QE x 1 us)
MAX_PIXELS = 100_000_000  # 100 Mpx (a 4096x3072 sensor is 12.6 Mpx)
MAX_SIDE = 65536


def light_max(full_well_e: float, qe: float) -> float:
    """The largest light level (photons/pixel/s) the simulator accepts."""
    return LIGHT_FULL_WELLS * full_well_e / (qe * 1e-6)


def array_problem(rows: int, cols: int) -> str | None:
    if rows > MAX_SIDE or cols > MAX_SIDE or rows * cols > MAX_PIXELS:
        return (f"a {cols}x{rows} simulated sensor is outside the simulator's range (at most {MAX_PIXELS:,} "
                f"pixels and {MAX_SIDE} per side)")
    return None


def setting_problem(key: str, value: float, full_well_e: float, qe: float) -> str | None:
    """Why ``value`` of scan quantity ``key`` is outside the simulator's range, or None."""
    if key == "temperature":
        lo, hi = TEMPERATURE_C
        if not lo <= value <= hi:
            return f"temperature {value:g} C is outside the simulator's range {lo:g} to {hi:g} C"
    elif key == "light":
        hi = light_max(full_well_e, qe)
        if value > hi:
            return (f"light level {value:g} photons/pixel/s is outside the simulator's range 0 to {hi:.3g} "
                    f"photons/pixel/s (1000 full wells of {full_well_e:g} e- per QE {qe:g} x 1 us)")
    return None
