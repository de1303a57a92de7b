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


RESIDUALS_P = 0.01  # the levels scatter about the model more than their errors say, at this chi2 probability


def split_noise(gain_dn_per_e, dark_var_dn2, dark_var_se=None, subtract_quantization: bool = True,
                gain_se=None) -> GainSplit:
    """Weighted least squares of ``var = a K^2 + b``; ``a = sigma_pixel_e^2``, ``b = sigma_chain^2``.

    ``gain_se``: each K's SE, carried into its variance's error through the model (2 a K se(K),
    effective variance): with many frames the dark variances are known to ~0.1 %, no better
    than K^2. The SEs are the errors' unless the residuals exceed them significantly (chi2
    probability < ``RESIDUALS_P``); then they are the residuals' with Student's t for n - 2
    dof (issue 48: the gain scan's 4 gains, 2 dof, at 16 frames gave the pixel noise 3.9 SE
    from the simulator's truth, "ok", its SE from the variances' counts alone)."""
    from ares.analysis.ptc.fit import residual_se_widening
    from ares.analysis.stats.tails import chi2_sf

    k = np.asarray(gain_dn_per_e, float)
    v = np.asarray(dark_var_dn2, float) - (1.0 / 12.0 if subtract_quantization else 0.0)
    if np.unique(k).size < 2:
        na = "needs dark noise at >= 2 different gains"
        return GainSplit(Estimate.na(na, "e-"), Estimate.na(na, "DN"), Estimate.na(na, "DN/e-"), math.nan)
    se0 = np.asarray(dark_var_se, float) if dark_var_se is not None else np.maximum(np.abs(v), 1e-12)
    kse = np.nan_to_num(np.asarray(gain_se, float)) if gain_se is not None else np.zeros_like(k)
    A = np.vstack([k**2, np.ones_like(k)]).T
    a_now = 0.0
    for _ in range(3):  # the K errors' share depends on a: iterate the effective variance
        se = np.hypot(se0, 2 * max(a_now, 0.0) * k * kse)
        w = 1.0 / se
        Aw = A * w[:, None]
        coef, *_ = np.linalg.lstsq(Aw, v * w, rcond=None)
        if not np.any(kse > 0):
            break
        a_now = float(coef[0])
    r = v * w - Aw @ coef
    dof = max(k.size - 2, 1)
    chi2 = float(r @ r) / dof
    cov = np.linalg.inv(Aw.T @ Aw)
    how = ""
    if dark_var_se is None:
        cov = cov * chi2  # relative errors only: the residuals set the scale
        how = f"; SE from the residuals x Student's t ({dof} dof)"
        cov = cov * residual_se_widening(dof) ** 2
    elif k.size > 2 and chi2 > 1 and chi2_sf(dof, chi2 * dof) < RESIDUALS_P:
        wt = residual_se_widening(dof)
        cov = cov * chi2 * wt * wt
        how = (f"; the gains scatter about the model {math.sqrt(chi2):.2g}x more than their errors (chi2/dof "
               f"{chi2:.3g}): SE from the residuals x Student's t ({dof} dof: x {wt:.3g})")
    s = np.sqrt(np.diag(cov))
    a, b = coef
    note = ("quantization 1/12 DN^2 subtracted" if subtract_quantization else "") + how
    pix = (Estimate(math.sqrt(a), s[0] / (2 * math.sqrt(a)), "e-", "pixel (input-referred) noise" + how)
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
