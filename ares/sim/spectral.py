"""The simulated spectral bench: a monochromator (a wavelength-selectable light source) and
a calibrated reference photodiode beside the sensor (EMVA 1288 4.0 Linear, Section 9.1).

The light source's level stays photons per pixel per second at the sensor (as everywhere on
the simulator), now at the monochromator's wavelength; the sensor turns them into charge
with its QE at that wavelength (``SensorParams.qe_at``: the truth of a spectral scan). The
photodiode, placed in the same irradiance, sees the power those photons carry over its
area -- the inverse of Eq. (3), ``mu_p = A E t_exp lambda / (h c)``:
``P = flux / A_pixel * A_pd * h c / lambda`` -- and reads ``I = R(lambda) P`` plus its dark
current and a little noise, ``R`` being its calibration table's responsivity (times
``1 + photodiode_error_pct / 100``: a calibration that is off by that much, in truth).
The line is taken as monochromatic at the set wavelength; its FWHM is reported.
"""

from __future__ import annotations

import math

import numpy as np

from ares.errors import ValueOutOfRange

H_PLANCK = 6.62607015e-34  # J s (SI 2019; EMVA 1288 4.0 Eq. 4 quotes 6.6260755e-34)
C_LIGHT = 2.99792458e8  # m/s


class GratingDrive:
    """How a stepper-driven grating moves, as a compact monochromator's does (Oriel/Newport
    Cornerstone-like): the drive accelerates at ``accel_nm_s2`` to its slew speed ``slew_nm_s``,
    runs, and decelerates (a trapezoid; a short move never reaches the slew speed: a triangle);
    backlash is taken out by always finishing a move upwards, so a move to a shorter wavelength
    runs ``backlash_nm`` past the target and comes back; after the drive stops, the grating mount
    rings for ``settle_s`` before the wavelength is steady. A move of ``d`` nm thus takes
    ``d / slew + slew / accel`` (``2 sqrt(d / accel)`` when short), plus the return leg when
    downwards, plus ``settle_s`` -- about 0.9 s for 100 nm at the defaults, and nothing for no move.
    The defaults are of the order such instruments show (a 1200 l/mm grating slews ~100-200 nm/s)."""

    def __init__(self, slew_nm_s: float = 150.0, accel_nm_s2: float = 1000.0, backlash_nm: float = 5.0,
                 settle_s: float = 0.05):
        for k, v in (("slew_nm_s", slew_nm_s), ("accel_nm_s2", accel_nm_s2)):
            if not (math.isfinite(v) and v > 0):
                raise ValueOutOfRange(f"grating drive: {k} {v!r} must be finite and > 0")
        for k, v in (("backlash_nm", backlash_nm), ("settle_s", settle_s)):
            if not (math.isfinite(v) and v >= 0):
                raise ValueOutOfRange(f"grating drive: {k} {v!r} must be finite and >= 0")
        self.slew, self.accel, self.backlash, self.settle_s = float(slew_nm_s), float(accel_nm_s2), \
            float(backlash_nm), float(settle_s)

    def leg_time(self, d: float) -> float:
        """Seconds the drive takes to move ``d`` nm (either way), stop to stop."""
        d = abs(d)
        if d * self.accel >= self.slew ** 2:
            return d / self.slew + self.slew / self.accel
        return 2.0 * math.sqrt(d / self.accel)

    def leg_position(self, d: float, tau: float) -> float:
        """How far (nm, 0 .. |d|) the drive has come ``tau`` s into a leg of ``d`` nm."""
        d, T = abs(d), self.leg_time(d)
        tau = min(max(tau, 0.0), T)
        ta = min(self.slew / self.accel, T / 2)  # accelerating (a triangle: half the leg)
        if tau <= ta:
            return 0.5 * self.accel * tau * tau
        if tau >= T - ta:
            return d - 0.5 * self.accel * (T - tau) ** 2
        return 0.5 * self.accel * ta * ta + self.slew * (tau - ta)

    def legs(self, start: float, target: float) -> list[float]:
        """The positions the drive stops at: the target, by way of target - backlash going down."""
        if target == start:
            return []
        return [target - self.backlash, target] if target < start and self.backlash > 0 else [target]


class SimMonochromator:
    """Wavelength-selectable light: ``set_wavelength`` (nm), ``get_wavelength``, ``bandwidth``
    (FWHM, nm); the simulated frame source reads the wavelength at every grab. With the bench's
    ``clock`` and a ``GratingDrive`` a change is a move that takes time: ``wavelength_at(t)`` is
    the grating's position (the wavelength it passes) at time ``t``, ``settled_at`` when the last
    move's ringing is over, ``moving(t0, t1)`` whether it moves inside a window; without them the
    wavelength is there at once."""

    MIN_NM, MAX_NM = 200.0, 2500.0
    HISTORY = 64  # legs kept: the wavelength at any time a frame in flight may ask about

    def __init__(self, fwhm_nm: float, name: str = "sim-monochromator", wavelength_nm: float = 550.0,
                 clock=None, drive: GratingDrive | None = None):
        self.name, self.fwhm_nm = name, float(fwhm_nm)
        self._nm = float(wavelength_nm)
        self.clock, self.drive = clock, (drive if clock is not None else None)
        self._rest = float(wavelength_nm)  # where the drive stood before its first leg kept
        self._legs: list[tuple] = []  # (start s, until s, from nm, to nm): the drive's moves
        self.settled_at = clock.now() if clock is not None else 0.0

    def set_wavelength(self, nm: float) -> None:
        v = float(nm)
        if not (math.isfinite(v) and self.MIN_NM <= v <= self.MAX_NM):
            raise ValueOutOfRange(f"{self.name}: wavelength {nm!r} nm is outside {self.MIN_NM:g} .. {self.MAX_NM:g} nm")
        self._nm = v
        if self.drive is None:
            return
        t = self.clock.now()
        here = self.wavelength_at(t)
        moved = False
        while self._legs and self._legs[-1][0] >= t:  # a leg not begun: replaced by the new move
            self._legs.pop()
        if self._legs and self._legs[-1][1] > t:  # interrupted: the drive stops where it is (an instant)
            s, _, a, b = self._legs.pop()
            self._legs.append((s, t, a, b))
            moved = True
        for stop in self.drive.legs(here, v):
            self._legs.append((t, t + self.drive.leg_time(stop - here), here, stop))
            t, here, moved = self._legs[-1][1], stop, True
        if len(self._legs) > self.HISTORY:
            self._rest = self._legs[-self.HISTORY - 1][3]
            del self._legs[:-self.HISTORY]
        if moved:  # steady once the drive has stopped and the mount has rung out
            self.settled_at = t + self.drive.settle_s

    def wavelength_at(self, t: float) -> float:
        """The wavelength the grating passes at time ``t`` (the set point without a drive)."""
        if self.drive is None:
            return self._nm
        for s, until, a, b in reversed(self._legs):
            if t >= s:
                if t >= until:
                    return b if until >= s + self.drive.leg_time(b - a) else \
                        a + math.copysign(self.drive.leg_position(b - a, until - s), b - a)
                return a + math.copysign(self.drive.leg_position(b - a, t - s), b - a)
        return self._rest

    def moving(self, t0: float, t1: float) -> bool:
        """Whether the drive moves at some time inside (t0, t1)."""
        return self.drive is not None and any(s < t1 and until > t0 for s, until, _, _ in self._legs)

    def get_wavelength(self) -> float:
        """The drive's position now (the set point once it has arrived)."""
        return self._nm if self.drive is None else self.wavelength_at(self.clock.now())

    def bandwidth(self) -> float:
        return self.fwhm_nm

    def settle(self, cancel=None) -> None:
        pass

    def close(self) -> None:
        pass


class SimPhotodiode:
    """The reference photodiode in the sensor's irradiance: ``read()`` gives the current (A,
    ``reading="current"``) or the power (W, ``reading="power"``, a power meter corrected at
    the wavelength it was told with ``set_wavelength``)."""

    def __init__(self, light, mono: SimMonochromator, params, pixel_pitch_um: float, area_mm2: float,
                 responsivity, reading: str = "current", seed: int = 0, name: str = "sim-photodiode"):
        """``responsivity(nm) -> A/W``: the calibration table's (``ares.analysis.optics.spectral_qe``)."""
        self.name, self.light, self.mono, self.reading = name, light, mono, reading
        self.pixel_area_m2 = (pixel_pitch_um * 1e-6) ** 2
        self.area_m2 = area_mm2 * 1e-6
        self.responsivity = responsivity
        self.scale = 1.0 + params.photodiode_error_pct / 100.0
        self.noise = params.photodiode_noise_pct / 100.0
        self.dark_a = params.photodiode_dark_a
        self.rng = np.random.default_rng([int(seed), 0x5EC7])
        self._meter_nm = 550.0

    def power_w(self) -> float:
        """The optical power on the photodiode now (W): the truth behind its reading -- the light
        source's output and the grating's position now."""
        nm = self.mono.get_wavelength()
        photon_j = H_PLANCK * C_LIGHT / (nm * 1e-9)
        out = getattr(self.light, "read_level", None)  # the output now (an LED still relaxing), not its set point
        return (out() if out is not None else self.light.get_level()) / self.pixel_area_m2 * self.area_m2 * photon_j

    def set_wavelength(self, nm: float) -> None:
        self._meter_nm = float(nm)

    def read(self) -> float:
        nm = self.mono.get_wavelength()
        r = self.responsivity(nm) * self.scale
        current = r * self.power_w() + self.dark_a
        current *= 1.0 + self.noise * self.rng.standard_normal()
        if self.reading == "current":
            return float(current)
        return float(current / self.responsivity(self._meter_nm))  # the meter's own correction

    def close(self) -> None:
        pass
