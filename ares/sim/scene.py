"""A rendering scene: the operating point of one ``render`` call, resolved to maps.

``resolve_scene`` checks the arguments (one clear InputError sentence each) and turns
them into the mean photo-charge ``q`` (e-), the mean dark charge (e-), the system gain
and the bias-dependent scale factors. Zero-valued components stay ``None``/0 so the
renderer skips them.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ares.errors import InputError
from ares.sim.edge import edge_map
from ares.sim.lowlight import dark_factor
from ares.sim.noise import SHOT_MODES
from ares.sim.params import SensorParams
from ares.sim.patterns import FixedPatterns


@dataclass
class Scene:
    exposure_s: float
    temperature_c: float
    analog_gain: float
    black_level_dn: float
    shot_noise: str
    G: float  # DN/e-
    q: float | np.ndarray  # mean photo-charge per pixel, e- (0.0 when dark)
    dark_e: np.ndarray | None  # mean dark charge per pixel incl. hot/warm, e- (None when zero)
    dark_clean_e: np.ndarray | None  # same without hot/warm pixels
    read_noise_e: float  # effective pixel read noise (after the sf_bias scale)
    dark_scale: float  # 2**((T-Tref)/Td) * dark_current_scale
    lag: float  # effective lag fraction


def _number(name, value, minimum=None, positive=False):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"simulator: '{name}' must be a number, not {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"simulator: '{name}' must be a finite number, not {value!r}")
    if positive and v <= 0:
        raise InputError(f"simulator: '{name}' must be greater than zero, not {v:g}")
    if minimum is not None and v < minimum:
        raise InputError(f"simulator: '{name}' must be at least {minimum:g}, not {v:g}")
    return v


def _crosstalk(q: np.ndarray, pct: float) -> np.ndarray:
    """Spread pct % of each pixel's mean charge equally to its 4 neighbours (edges reflect)."""
    k = pct / 100.0
    pad = np.pad(q, 1, mode="reflect")
    nb = pad[:-2, 1:-1] + pad[2:, 1:-1] + pad[1:-1, :-2] + pad[1:-1, 2:]
    return ((1.0 - k) * q + (k / 4.0) * nb).astype(np.float32)


@functools.lru_cache(maxsize=2)
def _edge(rows, cols, angle, sigma, low) -> np.ndarray:
    m = edge_map(rows, cols, angle, sigma, low)
    m.flags.writeable = False
    return m


def resolve_scene(p: SensorParams, fp: FixedPatterns, *, exposure_s, photon_flux, temperature_c, analog_gain,
                  black_level_dn, dark, shot_noise, read_noise_scale=1.0, dark_current_scale=1.0,
                  lag_scale=1.0) -> Scene:
    t = _number("exposure_s", exposure_s, minimum=0.0)
    temp = _number("temperature_c", temperature_c, minimum=-273.15)
    ag = _number("analog_gain", analog_gain, positive=True)
    black = _number("black_level_dn", black_level_dn)
    rns = _number("read_noise_scale", read_noise_scale, minimum=0.0)
    dcs = _number("dark_current_scale", dark_current_scale, minimum=0.0)
    lgs = _number("lag_scale", lag_scale, minimum=0.0)
    if shot_noise not in SHOT_MODES:
        raise InputError(f"simulator: shot_noise must be one of {', '.join(SHOT_MODES)}, not {shot_noise!r}")
    G = p.gain_dn_per_e(ag)

    q: float | np.ndarray = 0.0
    try:
        flux = np.asarray(photon_flux, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"simulator: photon_flux must be a number or a 2-D map, not {photon_flux!r}") from None
    if flux.ndim not in (0, 2):
        raise InputError(f"simulator: photon_flux must be a number or a 2-D map, not a {flux.ndim}-D array")
    if flux.ndim == 2 and flux.shape != (p.rows, p.cols):
        raise InputError(f"simulator: photon_flux map has shape {flux.shape}, the sensor is {(p.rows, p.cols)}")
    if not np.all(np.isfinite(flux)) or np.any(flux < 0):
        raise InputError("simulator: photon_flux must be finite and not negative (photons/pixel/s)")
    if p.illumination == "slanted_edge":
        flux = flux * _edge(p.rows, p.cols, p.edge_angle_deg, p.edge_psf_sigma_px, p.edge_low)
    lit = t > 0 and bool(np.any(flux > 0))
    if not dark and (lit or p.added_photocharge_e > 0):
        qq = flux * (t * p.qe)
        needs_map = flux.ndim == 2 or p.cfa is not None or p.ob_columns > 0
        if needs_map:
            qq = np.broadcast_to(qq, (p.rows, p.cols)).astype(np.float32)
            if p.cfa is not None:
                qq = qq * np.asarray(p.cfa_response, np.float32)[fp.phase]
            if p.crosstalk_pct > 0 and lit:
                qq = _crosstalk(qq, p.crosstalk_pct)
            qq = qq + np.float32(p.added_photocharge_e)
            qq[:, :p.ob_columns] = 0.0
            q = qq.astype(np.float32)
        else:
            q = float(qq) + p.added_photocharge_e

    factor = dark_factor(p, fp, temp)  # a number, or a per-pixel map under Arrhenius (ares.sim.lowlight)
    ds = float(np.mean(factor)) * dcs
    dark_e = dark_clean = None
    if t > 0 and ds > 0:
        f = np.float32(ds * t) if np.ndim(factor) == 0 else factor * np.float32(dcs * t)
        if np.any(fp.dark_all_ref_e_per_s):
            dark_e = fp.dark_all_ref_e_per_s * f
        if np.any(fp.dark_ref_e_per_s):
            dark_clean = fp.dark_ref_e_per_s * f
    return Scene(exposure_s=t, temperature_c=temp, analog_gain=ag, black_level_dn=black, shot_noise=shot_noise,
                 G=G, q=q, dark_e=dark_e, dark_clean_e=dark_clean, read_noise_e=p.read_noise_e * rns,
                 dark_scale=ds, lag=min(p.lag_fraction * lgs, 0.99))
