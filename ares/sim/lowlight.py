"""Low-light and thermal physics of the simulated sensor, with their truth:

* RTS dwell times: with ``rts_dwell_spread`` s > 1 each RTS pixel's mean dwell in its low and
  its high level (frames) is drawn log-uniform in [1/s, s] x 1/``rts_switch_prob`` (at least 1
  frame); each frame a pixel leaves its level with probability 1/dwell (geometric dwell times);
  with s = 1 every pixel switches with ``rts_switch_prob`` as before (the same draws).
* Dark current after Arrhenius, per pixel: with ``dark_activation_ev`` > 0 a pixel's dark
  current is ``I(T) = I_ref exp(-(Ea/k) (1/T - 1/T_ref))``, Ea drawn per pixel
  N(dark_activation_ev, dark_activation_sigma_ev) (hot and warm pixels: ``hot_activation_ev``
  when set); prefactor ``A = I_ref exp(Ea / (k T_ref))``, so ln A against Ea across pixels is
  the Meyer-Neldel line with isokinetic temperature T_ref. Otherwise the doubling law.
* Fe-55 X-rays: ``xray_events_per_frame`` (Poisson) photons at uniform positions, K-alpha
  5889 eV or K-beta 6490 eV (``xray_kbeta_fraction``), each freeing E / E_pair(T) electrons
  (``ares.analysis.lowlight.fe55``) with Fano noise (F = 0.12), spread over a 5x5 neighbourhood
  as a Gaussian cloud of ``xray_spread_px``.
"""

from __future__ import annotations

import math

import numpy as np

from ares.analysis.lowlight.fe55 import KALPHA_EV, KBETA_EV, pair_energy_ev

K_B_EV = 8.617333262e-5  # Boltzmann constant, eV/K
FANO = 0.12  # silicon's Fano factor
_F32 = np.float32


def rts_switch_probs(p, n: int, rng: np.random.Generator | None) -> tuple[np.ndarray, np.ndarray]:
    """(probability per frame of leaving the low level, of leaving the high level) per RTS pixel."""
    base = np.full(n, p.rts_switch_prob)
    if p.rts_dwell_spread <= 1 or n == 0 or rng is None or p.rts_switch_prob <= 0:
        return base, base.copy()
    ls = math.log(p.rts_dwell_spread)
    dwell = (1.0 / p.rts_switch_prob) * np.exp(rng.uniform(-ls, ls, (2, n)))
    dwell = np.maximum(dwell, 1.0)
    return 1.0 / dwell[0], 1.0 / dwell[1]


def activation_map(p, defects, shape, rng: np.random.Generator) -> np.ndarray | None:
    """Per-pixel activation energy (eV), or None under the doubling law."""
    if p.dark_activation_ev <= 0:
        return None
    ea = p.dark_activation_ev + p.dark_activation_sigma_ev * rng.standard_normal(shape)
    if p.hot_activation_ev > 0:
        flat = ea.reshape(-1)
        for name in ("hot", "warm"):
            flat[defects.index[name]] = p.hot_activation_ev
    return ea.astype(_F32)


def dark_factor(p, fp, temperature_c: float):
    """The dark-current factor at ``temperature_c`` relative to ``dark_ref_temp_c``: a number
    (doubling law) or a per-pixel float32 map (Arrhenius)."""
    ea = fp.activation_ev
    if ea is None:
        return p.dark_scale(temperature_c)
    t, tr = temperature_c + 273.15, p.dark_ref_temp_c + 273.15
    return np.exp(-(ea.astype(np.float64) / K_B_EV) * (1.0 / t - 1.0 / tr)).astype(_F32)


def dark_rate_map(p, fp, sc) -> np.ndarray:
    """Each pixel's dark current (e-/s, hot and warm pixels included) at the scene's operating point."""
    f = dark_factor(p, fp, sc.temperature_c)
    scale = sc.dark_scale / float(np.mean(f)) if float(np.mean(f)) > 0 else 0.0  # the bias-dependent factor
    return fp.dark_all_ref_e_per_s.astype(np.float64) * f * scale


def sparse_bumps(parts) -> tuple[np.ndarray, np.ndarray] | None:
    """One (sorted unique flat indices, summed DN) from several (indices, DN) pairs; None when empty."""
    parts = [(i, v) for i, v in parts if len(i)]
    if not parts:
        return None
    if len(parts) == 1 and np.all(np.diff(parts[0][0]) > 0):
        return parts[0]
    idx = np.concatenate([i for i, _ in parts])
    val = np.concatenate([v for _, v in parts]).astype(np.float64)
    u, inv = np.unique(idx, return_inverse=True)
    return u, np.bincount(inv, weights=val).astype(_F32)


def xray_deposits(rng: np.random.Generator, p, G: float, temperature_c: float, shape) -> tuple[np.ndarray, np.ndarray]:
    """(flat pixel indices, DN) of this frame's X-ray charge (indices may repeat)."""
    n = int(rng.poisson(p.xray_events_per_frame))
    if n == 0:
        return np.empty(0, np.int64), np.empty(0, _F32)
    R, C = shape
    y, x = rng.uniform(0, R, n), rng.uniform(0, C, n)
    kb = rng.random(n) < p.xray_kbeta_fraction
    mean_e = np.where(kb, KBETA_EV, KALPHA_EV) / pair_energy_ev(temperature_c)[0]
    ne = mean_e + np.sqrt(FANO * mean_e) * rng.standard_normal(n)
    s = max(p.xray_spread_px, 1e-6)
    d = np.arange(-2, 3)
    erf = np.vectorize(math.erf)

    def frac(pos):  # charge fraction in the pixels floor(pos) + d
        lo = (np.floor(pos)[:, None] + d[None, :] - pos[:, None]) / (s * math.sqrt(2))
        return 0.5 * (erf(lo + 1 / (s * math.sqrt(2))) - erf(lo))

    fy, fx = frac(y), frac(x)
    rr = np.floor(y).astype(np.int64)[:, None, None] + d[None, :, None]
    cc = np.floor(x).astype(np.int64)[:, None, None] + d[None, None, :]
    q = ne[:, None, None] * fy[:, :, None] * fx[:, None, :]
    rr, cc = np.broadcast_to(rr, q.shape), np.broadcast_to(cc, q.shape)
    ok = (rr >= 0) & (rr < R) & (cc >= 0) & (cc < C) & (q > 0)
    return (rr[ok] * C + cc[ok]).astype(np.int64), (G * q[ok]).astype(_F32)


def truth(sensor, sc) -> dict:
    """The truth of this module's physics at the scene's operating point."""
    p, fp = sensor.params, sensor.patterns
    d = fp.defects
    with np.errstate(divide="ignore"):  # a trap that never switches: an infinite dwell
        out = {"rts_dwell_low_frames": 1.0 / fp.rts_p_up, "rts_dwell_high_frames": 1.0 / fp.rts_p_down,
               "rts_amplitude_dn": sc.G * d.rts_amplitude_e}
    if fp.activation_ev is not None:
        ea = fp.activation_ev.astype(np.float64)
        ref = fp.dark_all_ref_e_per_s.astype(np.float64)
        tr = p.dark_ref_temp_c + 273.15
        with np.errstate(divide="ignore"):
            ln_a = np.log(ref) + ea / (K_B_EV * tr)
        out["arrhenius"] = {"activation_ev": ea, "ln_prefactor_e_per_s": ln_a, "isokinetic_temperature_k": tr,
                            "meyer_neldel_ev": K_B_EV * tr}
    if p.xray_events_per_frame > 0:
        ne = KALPHA_EV / pair_energy_ev(sc.temperature_c)[0]
        out["xray"] = {"kalpha_e": ne, "kalpha_dn": sc.G * ne, "gain_e_per_dn": 1.0 / sc.G}
    return out
