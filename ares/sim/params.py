"""Parameters of the simulated sensor (ARTEMIS "Pixel", "Analog" and "ADC" tabs).

One frozen dataclass, ``SensorParams``. Field names carry their unit. Electrons (e-)
are pixel-domain quantities; they reach the output through the system gain
``G [DN/e-] = conversion_gain_uv_per_e * analog_gain / adc_lsb_uv``. DN quantities are
at the ADC input (after the analog gain), so they do not scale with the analog gain.
G is the realized array's mean conversion gain: the column, row and pixel gain
non-uniformity maps are drawn with their sigmas and scaled to mean exactly 1
(``patterns.py``). What a photon-transfer fit measures departs from G by the sensor's
physics, not by the seed: the gain spread (x (1 + var g), ~ +1e-4 at 1 % PRNU), image lag
(x ~ (1 - 2 lag)) and an ADC INL bow (codes per DN at the signal where the slope is taken).

Defaults describe a plausible small CMOS sensor: 640x480, 3.3 um pixels, 12 ke- full
well, 70 uV/e-, 2.5 e- read noise, 12-bit ADC with a 250 uV LSB (G = 0.28 DN/e- at x1).
Dark-current figures are given at ``dark_ref_temp_c`` (60 C) and double every
``dark_doubling_c`` (8 C): ``X(T) = X_60 * 2**((T - 60) / 8)`` (seed 001).

ARTEMIS GUI field -> field here: Pixel Pitch -> pixel_pitch_um; Full Well ->
full_well_e; C. Gain -> conversion_gain_uv_per_e; Read Noise -> read_noise_e; Dark
Current -> dark_current_e_per_s; DSNU -> dsnu_e_per_s; MPFPN -> pixel_fpn_e; Crosstalk ->
crosstalk_pct; PRNU e,e / o,e / e,o / o,o -> prnu_pct; Hot Rate / Hot Mean ->
hot_rate_ppm / hot_mean_e_per_s; RTS Rate / RTS Mean -> rts_rate_ppm / rts_amplitude_e;
Added Photocharge -> added_photocharge_e; Flutter -> flutter_pct; First Pixel Color ->
cfa; Response Factor 0-3 -> cfa_response. Shot Noise Enable has no field: shot noise is
physics here; ``render(shot_noise=...)`` chooses exact or Gaussian draws.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

from ares.errors import InputError
from ares.sim.ranges import array_problem

#: Bayer patterns accepted for ``cfa``; the letters name phases (0,0), (0,1), (1,0), (1,1)
#: as (row % 2, column % 2).
CFA_PATTERNS = ("RGGB", "GRBG", "GBRG", "BGGR")

# Fields that must be >= 0 (noise sigmas, rates, amplitudes, ...).
_NON_NEGATIVE = (
    "pixel_pitch_um", "read_noise_e", "chain_noise_dn", "col_fpn_dn", "row_fpn_dn",
    "pixel_fpn_e", "col_temporal_dn", "row_temporal_dn", "frame_global_dn",
    "dark_current_e_per_s", "dsnu_e_per_s", "dark_tail_e_per_s", "col_gain_pct",
    "row_gain_pct", "hot_rate_ppm", "hot_mean_e_per_s", "warm_rate_ppm",
    "warm_mean_e_per_s", "rts_rate_ppm", "rts_amplitude_e", "dead_rate_ppm",
    "stuck_rate_ppm", "noisy_rate_ppm", "bad_column_offset_dn", "crosstalk_pct",
    "adc_inl_lsb", "adc_dnl_lsb", "lag_fraction", "added_photocharge_e", "flutter_pct",
    "mono_fwhm_nm", "mono_backlash_nm", "mono_settle_s", "photodiode_noise_pct", "photodiode_dark_a",
    "dark_activation_ev", "dark_activation_sigma_ev", "hot_activation_ev", "xray_events_per_frame", "xray_spread_px",
)
_POSITIVE = ("full_well_e", "conversion_gain_uv_per_e", "adc_lsb_uv", "qe", "dark_doubling_c", "mono_slew_nm_s",
             "mono_accel_nm_s2", "offset_warmup_tau_s")
_PPM = ("hot_rate_ppm", "warm_rate_ppm", "rts_rate_ppm", "dead_rate_ppm", "stuck_rate_ppm", "noisy_rate_ppm")


@dataclass(frozen=True)
class SensorParams:
    """Every knob of the Monte Carlo sensor (see the module docstring for units)."""

    # --- geometry ---------------------------------------------------------------
    rows: int = 480
    cols: int = 640
    pixel_pitch_um: float = 3.3
    ob_columns: int = 0  # optically black columns on the left: dark current, no photo-charge

    # --- pixel: charge and conversion --------------------------------------------
    full_well_e: float = 12000.0  # pixel charge clips here (photo + dark)
    conversion_gain_uv_per_e: float = 70.0
    qe: float = 0.6  # photo-electrons per photon at the pixel
    crosstalk_pct: float = 1.0  # % of mean photo-charge spread to the 4 nearest neighbours
    lag_fraction: float = 0.0  # fraction of a frame's photo-charge read out in the next frame
    added_photocharge_e: float = 0.0  # ARTEMIS "Added Photocharge": e- added to every active pixel's mean
    flutter_pct: float = 0.0  # ARTEMIS "Flutter": per-frame illumination scale 1 + flutter/100 * N(0,1)

    # --- temporal noise ---------------------------------------------------------------
    read_noise_e: float = 2.5  # pixel temporal noise (before the analog gain), Gaussian
    chain_noise_dn: float = 0.5  # analog chain + ADC temporal noise (after the gain), Gaussian
    col_temporal_dn: float = 0.3  # Ct: per column and frame
    row_temporal_dn: float = 0.4  # Rt: per row and frame
    frame_global_dn: float = 0.2  # whole-frame offset per frame (flicker, clamp drift)

    # --- offset drift on the bench's clock (ares.sim.drift; all 0: none) ---------------------
    offset_warmup_dn: float = 0.0  # the black level's change from power-up (bench clock 0) to the warm die, DN
    offset_warmup_tau_s: float = 300.0  # ... approached with this time constant (the die's thermal one), s
    offset_drift_dn_per_s: float = 0.0  # a slow linear drift on top (the chamber's regulation, the clamp), DN/s

    # --- offset fixed-pattern noise ------------------------------------------------------
    col_fpn_dn: float = 1.0  # Cs: column offset FPN sigma
    row_fpn_dn: float = 0.5  # Rs: row offset FPN sigma
    pixel_fpn_e: float = 1.0  # Ps1: "minimal" pixel offset FPN (ARTEMIS MPFPN), Gaussian

    # --- dark current (at dark_ref_temp_c) --------------------------------------------------
    dark_current_e_per_s: float = 50.0  # mean dark current
    dsnu_e_per_s: float = 10.0  # Ps2: Gaussian spread of the pixel dark current
    dark_tail_e_per_s: float = 5.0  # Ps3: exponential tail (mean of the zero-centred exponential)
    dark_ref_temp_c: float = 60.0
    dark_doubling_c: float = 8.0
    dark_activation_ev: float = 0.0  # > 0: per-pixel Arrhenius law instead of the doubling (ares.sim.lowlight)
    dark_activation_sigma_ev: float = 0.0  # pixel-to-pixel sigma of the activation energy
    hot_activation_ev: float = 0.0  # > 0: the hot and warm pixels' activation energy (field-enhanced traps)
    xray_events_per_frame: float = 0.0  # Fe-55 X-rays absorbed per frame (Poisson; ares.sim.lowlight)
    xray_kbeta_fraction: float = 0.12  # fraction of them at K-beta (6490 eV) instead of K-alpha (5889 eV)
    xray_spread_px: float = 0.25  # Gaussian sigma of an X-ray's charge cloud, pixels

    # --- gain non-uniformity ----------------------------------------------------------------
    prnu_pct: tuple = (1.0, 1.0, 1.0, 1.0)  # Pg sigma per Bayer phase (r%2,c%2): ee, eo, oe, oo
    col_gain_pct: float = 0.2  # Cg sigma
    row_gain_pct: float = 0.1  # Rg sigma
    cfa: str | None = None  # None (monochrome) or one of CFA_PATTERNS
    cfa_response: tuple = (1.0, 1.0, 1.0, 1.0)  # response factor per phase (used when cfa is set)

    # --- defects ------------------------------------------------------------------------
    hot_rate_ppm: float = 50.0
    hot_mean_e_per_s: float = 2000.0  # extra dark current, uniform in [0.5, 1.5] x mean (at 60 C)
    warm_rate_ppm: float = 200.0
    warm_mean_e_per_s: float = 300.0
    rts_rate_ppm: float = 100.0
    rts_amplitude_e: float = 20.0  # bistable amplitude, uniform in [0.5, 1.5] x mean
    rts_switch_prob: float = 0.1  # probability per frame that an RTS pixel changes state
    rts_dwell_spread: float = 1.0  # >= 1: each RTS pixel's mean dwell in each level is log-uniform in
    #   [1/s, s] x 1/rts_switch_prob frames (1: every pixel switches with rts_switch_prob; ares.sim.lowlight)
    dead_rate_ppm: float = 20.0
    dead_response: float = 0.3  # photo-response fraction of a dead pixel
    stuck_rate_ppm: float = 5.0
    stuck_code_dn: int | None = None  # None: each stuck pixel gets a random code
    noisy_rate_ppm: float = 100.0
    noisy_factor: float = 5.0  # read-noise multiplier of a noisy pixel
    bad_columns: int = 0
    bad_column_offset_dn: float = 20.0

    # --- ADC ----------------------------------------------------------------------------
    adc_bits: int = 12
    adc_lsb_uv: float = 250.0
    adc_offset_dn: tuple = (0.0, 1.5)  # ADC channel 0 (even columns), 1 (odd columns)
    adc_gain: tuple = (1.0, 1.0)
    adc_inl_lsb: float = 0.0  # amplitude of a smooth (half-sine) INL bow, in LSB
    adc_dnl_lsb: float = 0.0  # sigma of the random per-code width error, in LSB

    # --- fidelity -----------------------------------------------------------------------
    shot_noise: str = "auto"  # "auto" (exact Poisson where distinguishable), "exact", "gaussian"

    # --- illumination pattern (ares.sim.edge) ----------------------------------------------
    illumination: str = "uniform"  # "uniform" or "slanted_edge" (the light level is the bright side's)
    edge_angle_deg: float = 5.0  # slanted edge: tilt from the vertical
    edge_psf_sigma_px: float = 0.6  # slanted edge: Gaussian optical PSF width, pixels
    edge_low: float = 0.25  # slanted edge: dark side's illumination relative to the bright side

    # --- spectral response (ares.sim.spectral; used when a monochromator is on the bench) ---
    qe_curve_nm: tuple = ()  # wavelengths (nm, increasing) of the QE(lambda) table; () = flat at qe
    qe_curve: tuple = ()  # QE at those wavelengths (0..1), linear between them, the end values beyond
    mono_fwhm_nm: float = 5.0  # simulated monochromator's bandwidth (FWHM); the line is taken as monochromatic
    mono_slew_nm_s: float = 150.0  # its grating drive (ares.sim.spectral.GratingDrive): slew speed,
    mono_accel_nm_s2: float = 1000.0  # acceleration,
    mono_backlash_nm: float = 5.0  # the overshoot of a move downwards (the last approach is upwards),
    mono_settle_s: float = 0.05  # and the mount's ringing after the drive stops
    photodiode_noise_pct: float = 0.1  # reference photodiode: relative noise of one reading (Gaussian)
    photodiode_dark_a: float = 2e-11  # reference photodiode: dark current (A) under every reading
    photodiode_error_pct: float = 0.0  # its true responsivity differs from its calibration table by this

    # ------------------------------------------------------------------------------
    def __post_init__(self):
        for name in ("prnu_pct", "cfa_response", "adc_offset_dn", "adc_gain"):
            value = getattr(self, name)
            if isinstance(value, (int, float)):
                value = (value,) * (4 if name in ("prnu_pct", "cfa_response") else 2)
            try:
                value = tuple(float(v) for v in value)
            except (TypeError, ValueError):
                raise InputError(f"simulator parameter '{name}' must be a list of numbers") from None
            object.__setattr__(self, name, value)
        for name in ("qe_curve_nm", "qe_curve"):
            try:
                object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
            except (TypeError, ValueError):
                raise InputError(f"simulator parameter '{name}' must be a list of numbers") from None
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(f.default, float):
                if isinstance(v, bool) or not isinstance(v, (int, float)):
                    raise InputError(f"simulator parameter '{f.name}' must be a number, not {v!r}")
                object.__setattr__(self, f.name, float(v))
        if isinstance(self.cfa, str):
            object.__setattr__(self, "cfa", None if self.cfa.lower() in ("", "mono", "none") else self.cfa.upper())
        if self.stuck_code_dn is not None and (isinstance(self.stuck_code_dn, bool)
                                               or not isinstance(self.stuck_code_dn, int)):
            self._fail("stuck_code_dn", "must be None or an integer code")
        self._validate()

    def _fail(self, name: str, why: str):
        raise InputError(f"simulator parameter '{name}' = {getattr(self, name)!r} {why}")

    def _validate(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float) and not math.isfinite(v):
                self._fail(f.name, "is not a finite number")
            if isinstance(v, tuple) and not all(math.isfinite(x) for x in v):
                self._fail(f.name, "holds a value that is not a finite number")
        for name in ("rows", "cols", "adc_bits", "ob_columns", "bad_columns"):
            if not isinstance(getattr(self, name), int) or isinstance(getattr(self, name), bool):
                self._fail(name, "must be an integer")
        if self.rows < 2 or self.cols < 2:
            self._fail("rows" if self.rows < 2 else "cols", "must be at least 2")
        why = array_problem(self.rows, self.cols)  # (a system file says so at its <array> line first)
        if why:
            raise InputError(f"simulator parameters 'rows', 'cols': {why}")
        if not 1 <= self.adc_bits <= 16:
            self._fail("adc_bits", "must be between 1 and 16")
        for name in _NON_NEGATIVE:
            if getattr(self, name) < 0:
                self._fail(name, "must not be negative")
        for name in _POSITIVE:
            if getattr(self, name) <= 0:
                self._fail(name, "must be greater than zero")
        if self.qe > 1:
            self._fail("qe", "must not exceed 1")
        if not 0 <= self.ob_columns < self.cols:
            self._fail("ob_columns", "must be between 0 and cols - 1")
        if not 0 <= self.bad_columns <= self.cols - self.ob_columns:
            self._fail("bad_columns", "must be between 0 and the number of active columns")
        if self.crosstalk_pct >= 50:
            self._fail("crosstalk_pct", "must be below 50 %")
        if self.lag_fraction >= 1:
            self._fail("lag_fraction", "must be below 1")
        if self.shot_noise not in ("auto", "exact", "gaussian"):
            self._fail("shot_noise", "must be 'auto', 'exact' or 'gaussian'")
        if self.illumination not in ("uniform", "slanted_edge"):
            self._fail("illumination", "must be 'uniform' or 'slanted_edge'")
        if self.edge_psf_sigma_px <= 0 or not 0 <= self.edge_low < 1 or abs(self.edge_angle_deg) >= 45:
            self._fail("edge_psf_sigma_px", "must be > 0, with edge_low in [0, 1) and |edge_angle_deg| < 45")
        self._validate_qe_curve()
        if self.photodiode_error_pct <= -100:
            self._fail("photodiode_error_pct", "must be above -100 %")
        if not 0 <= self.dead_response < 1:
            self._fail("dead_response", "must be in [0, 1)")
        if not 0 <= self.rts_switch_prob <= 1:
            self._fail("rts_switch_prob", "must be in [0, 1]")
        if self.rts_dwell_spread < 1:
            self._fail("rts_dwell_spread", "must be at least 1")
        if not 0 <= self.xray_kbeta_fraction <= 1:
            self._fail("xray_kbeta_fraction", "must be in [0, 1]")
        for name in ("dark_activation_ev", "hot_activation_ev"):
            if getattr(self, name) > 3.0:
                self._fail(name, "must be at most 3 eV (silicon's band gap is 1.12 eV)")
        if self.dark_activation_sigma_ev > 0.5:
            self._fail("dark_activation_sigma_ev", "must be at most 0.5 eV")
        if self.xray_spread_px > 1.0:
            self._fail("xray_spread_px", "must be at most 1 pixel (an X-ray's charge is spread over 5x5 pixels)")
        if self.xray_events_per_frame > 0.01 * self.rows * self.cols + 1:
            self._fail("xray_events_per_frame", "must be at most 1 % of the pixels (events would pile up)")
        if self.noisy_factor < 1:
            self._fail("noisy_factor", "must be at least 1")
        if sum(getattr(self, n) for n in _PPM) > 1e6:
            self._fail("hot_rate_ppm", "plus the other defect rates exceeds 1e6 ppm")
        if len(self.prnu_pct) != 4 or min(self.prnu_pct) < 0:
            self._fail("prnu_pct", "must be four non-negative percentages (one per Bayer phase)")
        if len(self.cfa_response) != 4 or min(self.cfa_response) < 0:
            self._fail("cfa_response", "must be four non-negative response factors (one per Bayer phase)")
        if len(self.adc_offset_dn) != 2:
            self._fail("adc_offset_dn", "must be two offsets (even, odd columns)")
        if len(self.adc_gain) != 2 or min(self.adc_gain) <= 0:
            self._fail("adc_gain", "must be two positive gains (even, odd columns)")
        if self.cfa is not None and self.cfa not in CFA_PATTERNS:
            self._fail("cfa", f"must be None or one of {', '.join(CFA_PATTERNS)}")
        if self.stuck_code_dn is not None and not 0 <= self.stuck_code_dn < (1 << self.adc_bits):
            self._fail("stuck_code_dn", "must be None or a code of the ADC")

    def _validate_qe_curve(self):
        nm, qe = self.qe_curve_nm, self.qe_curve
        if len(nm) != len(qe):
            self._fail("qe_curve", f"has {len(qe)} values for {len(nm)} wavelengths in qe_curve_nm")
        if nm and len(nm) < 2:
            self._fail("qe_curve_nm", "needs at least 2 wavelengths (or none: QE flat at qe)")
        if any(b <= a for a, b in zip(nm, nm[1:])) or (nm and nm[0] <= 0):
            self._fail("qe_curve_nm", "must be positive wavelengths in increasing order")
        if any(not 0 <= v <= 1 for v in qe):
            self._fail("qe_curve", "must hold quantum efficiencies between 0 and 1")

    def qe_at(self, wavelength_nm: float) -> float:
        """The simulated sensor's QE at ``wavelength_nm`` (the truth of a spectral scan): the
        ``qe_curve`` table, linear between its points and its end values beyond; ``qe``
        without a table."""
        nm, qe = self.qe_curve_nm, self.qe_curve
        if not nm:
            return self.qe
        if wavelength_nm <= nm[0]:
            return qe[0]
        if wavelength_nm >= nm[-1]:
            return qe[-1]
        i = next(k for k in range(1, len(nm)) if nm[k] >= wavelength_nm)
        f = (wavelength_nm - nm[i - 1]) / (nm[i] - nm[i - 1])
        return qe[i - 1] + f * (qe[i] - qe[i - 1])

    # ------------------------------------------------------------------------------
    @property
    def max_code(self) -> int:
        """Largest ADC output code, 2**adc_bits - 1."""
        return (1 << self.adc_bits) - 1

    def gain_dn_per_e(self, analog_gain: float = 1.0) -> float:
        """System gain G in DN/e- = conversion_gain_uv_per_e * analog_gain / adc_lsb_uv."""
        return self.conversion_gain_uv_per_e * analog_gain / self.adc_lsb_uv

    def dark_scale(self, temperature_c: float) -> float:
        """Factor 2**((T - T_ref) / T_doubling) applied to every dark-current figure."""
        return 2.0 ** ((temperature_c - self.dark_ref_temp_c) / self.dark_doubling_c)

    def to_dict(self) -> dict:
        """Plain dict of every field (tuples become lists), inverse of ``from_dict``."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict) -> "SensorParams":
        """Build from a dict; unknown keys raise one InputError naming them."""
        if not isinstance(d, dict):
            raise InputError(f"simulator parameters must be a mapping of names to values, not {type(d).__name__}")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            names = ", ".join(f"'{u}'" for u in unknown)
            s = "s" if len(unknown) > 1 else ""
            raise InputError(f"unknown simulator parameter{s} {names}")
        return cls(**d)

    def replace(self, **changes) -> "SensorParams":
        """A copy with some fields changed (validated; unknown names raise InputError)."""
        return SensorParams.from_dict({**self.to_dict(), **changes})

    def without_defects(self) -> "SensorParams":
        """A copy with every defect class switched off (clean truth for noise analyses)."""
        return self.replace(hot_rate_ppm=0.0, warm_rate_ppm=0.0, rts_rate_ppm=0.0, dead_rate_ppm=0.0,
                            stuck_rate_ppm=0.0, noisy_rate_ppm=0.0, bad_columns=0)

    def noiseless(self) -> "SensorParams":
        """A copy with every random component (temporal, fixed pattern, defect) at zero.

        Shot noise remains (it is physics, switched by ``render(shot_noise=...)`` only
        through ``photon_flux``); useful to isolate one component in tests.
        """
        zero = {n: 0.0 for n in ("read_noise_e", "chain_noise_dn", "col_temporal_dn", "row_temporal_dn",
                                 "frame_global_dn", "col_fpn_dn", "row_fpn_dn", "pixel_fpn_e",
                                 "dark_current_e_per_s", "dsnu_e_per_s", "dark_tail_e_per_s",
                                 "col_gain_pct", "row_gain_pct", "crosstalk_pct", "adc_inl_lsb", "adc_dnl_lsb",
                                 "lag_fraction", "flutter_pct")}
        zero.update(prnu_pct=(0.0,) * 4, adc_offset_dn=(0.0, 0.0), adc_gain=(1.0, 1.0))
        return self.without_defects().replace(**zero)
