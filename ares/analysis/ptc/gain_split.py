"""Dark temporal noise vs analog gain, split into pixel (input) and chain (output) noise.

Model (seed 001, "Dark temporal noise as f(analog gain)"):
``sigma_DN^2 = sigma_pixel_e^2 * K(g)^2 + sigma_chain_DN^2``, with ``K(g)`` the system
gain in DN/e- at analog gain ``g`` (measured per gain, or ``K_1 * g``). Dividing by
``K^2`` gives the seed's input-referred form
``sigma_e = sqrt(sigma_pixel^2 + sigma_chain^2 * (1/K)^2)`` -- in its notation
``sqrt(sigma_pixel^2/g_c^2 + sigma_chain^2 g_f^2)`` with ``g_f = 1/K`` in e-/DN.

Quantization (1/12 DN^2, after the chain) is subtracted from the variances by default,
so the chain term is the analog chain's own noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.estimate import Estimate


@dataclass(frozen=True)
class GainSplit:
    pixel_noise_e: Estimate
    chain_noise_dn: Estimate
    crossover_gain_dn_per_e: Estimate  # K at which both terms are equal
    chi2_red: float


def split_noise(gain_dn_per_e, dark_var_dn2, dark_var_se=None, subtract_quantization: bool = True) -> GainSplit:
    """Weighted least squares of ``var = a K^2 + b``; ``a = sigma_pixel_e^2``, ``b = sigma_chain^2``."""
    k = np.asarray(gain_dn_per_e, float)
    v = np.asarray(dark_var_dn2, float) - (1.0 / 12.0 if subtract_quantization else 0.0)
    if np.unique(k).size < 2:
        na = "needs dark noise at >= 2 different gains"
        return GainSplit(Estimate.na(na, "e-"), Estimate.na(na, "DN"), Estimate.na(na, "DN/e-"), math.nan)
    se = np.asarray(dark_var_se, float) if dark_var_se is not None else np.maximum(np.abs(v), 1e-12)
    w = 1.0 / se
    A = np.vstack([k**2, np.ones_like(k)]).T
    Aw = A * w[:, None]
    coef, *_ = np.linalg.lstsq(Aw, v * w, rcond=None)
    r = v * w - Aw @ coef
    dof = max(k.size - 2, 1)
    chi2 = float(r @ r) / dof
    cov = np.linalg.inv(Aw.T @ Aw) * (max(chi2, 1.0) if dark_var_se is not None else chi2)
    s = np.sqrt(np.diag(cov))
    a, b = coef
    note = "quantization 1/12 DN^2 subtracted" if subtract_quantization else ""
    pix = (Estimate(math.sqrt(a), s[0] / (2 * math.sqrt(a)), "e-", "pixel (input-referred) noise")
           if a > 0 else Estimate.na("fitted pixel variance <= 0", "e-"))
    ch = (Estimate(math.sqrt(b), s[1] / (2 * math.sqrt(b)), "DN", "chain (output-referred) noise; " + note)
          if b > 0 else Estimate.na("fitted chain variance <= 0 (" + note + ")", "DN"))
    if a > 0 and b > 0:
        kc = math.sqrt(b / a)
        kc_se = 0.5 * kc * math.hypot(s[0] / a, s[1] / b)
        cross = Estimate(kc, kc_se, "DN/e-", "gain where pixel and chain noise are equal")
    else:
        cross = Estimate.na("needs both terms", "DN/e-")
    return GainSplit(pix, ch, cross, chi2)


def pixel_noise_uv(split: GainSplit, conversion_gain_uv_per_e: float) -> Estimate:
    """Pixel noise as a voltage at the sense node (the seed's sigma_pixel; g_c in uV/e-)."""
    e = split.pixel_noise_e
    if not e.available:
        return Estimate.na(e.note, "uV")
    return Estimate(e.value * conversion_gain_uv_per_e, e.se * conversion_gain_uv_per_e, "uV",
                    "pixel noise x conversion gain")


def input_referred_noise_e(split: GainSplit, gain_dn_per_e) -> np.ndarray:
    """Model input-referred noise (e-) at the given system gains."""
    k = np.asarray(gain_dn_per_e, float)
    return np.sqrt(split.pixel_noise_e.value**2 + (split.chain_noise_dn.value / k) ** 2)
