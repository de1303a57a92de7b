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


class SimMonochromator:
    """Wavelength-selectable light: ``set_wavelength`` (nm), ``get_wavelength``, ``bandwidth``
    (FWHM, nm); the simulated frame source reads the wavelength at every grab."""

    MIN_NM, MAX_NM = 200.0, 2500.0

    def __init__(self, fwhm_nm: float, name: str = "sim-monochromator", wavelength_nm: float = 550.0):
        self.name, self.fwhm_nm = name, float(fwhm_nm)
        self._nm = float(wavelength_nm)

    def set_wavelength(self, nm: float) -> None:
        v = float(nm)
        if not (math.isfinite(v) and self.MIN_NM <= v <= self.MAX_NM):
            raise ValueOutOfRange(f"{self.name}: wavelength {nm!r} nm is outside {self.MIN_NM:g} .. {self.MAX_NM:g} nm")
        self._nm = v

    def get_wavelength(self) -> float:
        return self._nm

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
        """The optical power on the photodiode now (W): the truth behind its reading."""
        nm = self.mono.get_wavelength()
        photon_j = H_PLANCK * C_LIGHT / (nm * 1e-9)
        return self.light.get_level() / self.pixel_area_m2 * self.area_m2 * photon_j

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
