"""Spectral quantum efficiency, EMVA 1288 4.0 Linear Section 9 (spectral sensitivity).

For every wavelength of a monochromator sweep (Section 9.4, Eq. 82)::

    eta(lambda) = (mu_y(lambda) - mu_y.dark) / (K mu_p(lambda))

with ``K`` from photon transfer at the same operation point (Section 9.2) and ``mu_p`` the
photons per pixel from the irradiance a calibrated reference photodiode measured in the
sensor's place (Section 9.3) by Eq. (3): ``mu_p = A E t_exp lambda / (h c)``, ``A`` the
pixel area, ``E = P / A_pd`` the irradiance, ``P = (I - I_dark) / R(lambda)`` the power
from the photodiode's current and its calibrated responsivity (or the power a power meter
reads directly).

The relative uncertainty of each point combines, in quadrature, the calibration table's
uncertainty of ``R`` at that wavelength (linear between its points), the SE of ``K``, the SE
of the net mean signal (from the scatter of the frame means of the light and dark stacks)
and the SE of the net photodiode reading. A wavelength outside the calibration table, a
saturated point (pixels at the top code, or a temporal variance below half the shot noise
K x signal: clipped at the full well) or one too dark to measure (net signal below 5 dark
temporal sigmas) is "not available" with the reason.

Pure: numbers in, Estimates out (``ares.results.spectral_qe`` feeds it a run).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ares.analysis.stats.estimate import Estimate

H_PLANCK = 6.62607015e-34  # J s (SI; Eq. 4 of the standard quotes 6.6260755e-34: 5e-7 relative)
C_LIGHT = 2.99792458e8  # m/s
SATURATED_FRACTION = 0.001  # more pixels than this at the top code: the point is saturated
SHOT_FRACTION = 0.5  # a temporal variance below this share of the shot noise K x signal: the pixels clip
DARK_SIGMAS = 5.0  # a net signal below this many dark temporal sigmas is too dark to measure


def spectral_groups(stages: list[dict]) -> set[str]:
    """The stage groups (``<sweep>`` names) that sweep the wavelength: two or more distinct
    ``wavelength`` settings. Their stages are spectral points, not photon-transfer levels
    (the photons per pixel of a photon-transfer level are light x exposure at one wavelength)."""
    by_group: dict[str, set] = {}
    for st in stages:
        if "wavelength" in st["settings"]:
            by_group.setdefault(st["group"], set()).add(st["settings"]["wavelength"])
    return {g for g, w in by_group.items() if len(w) >= 2}


def responsivity_at(nm_table, r_table, u_table, nm: float) -> tuple[float, float] | None:
    """(R, u(R)) in A/W at ``nm``, linear between the table's points; None outside it."""
    if not nm_table[0] <= nm <= nm_table[-1]:
        return None
    i = next(k for k in range(1, len(nm_table)) if nm_table[k] >= nm)
    f = (nm - nm_table[i - 1]) / (nm_table[i] - nm_table[i - 1])
    return (r_table[i - 1] + f * (r_table[i] - r_table[i - 1]), u_table[i - 1] + f * (u_table[i] - u_table[i - 1]))


def photons_per_pixel(power_w: float, pd_area_m2: float, pixel_area_m2: float, exposure_s: float,
                      wavelength_nm: float) -> float:
    """Eq. (3): mu_p = A E t_exp / (h c / lambda), E = P / A_pd."""
    return pixel_area_m2 * (power_w / pd_area_m2) * exposure_s * (wavelength_nm * 1e-9) / (H_PLANCK * C_LIGHT)


@dataclass(frozen=True)
class SpectralPoint:
    """One wavelength's measurement: the light and dark stacks' means (DN) with their SEs,
    the dark temporal sigma (DN), the fraction of pixels at the top code, and the
    photodiode's mean readings (A, or W for a power meter) with light and without."""

    wavelength_nm: float
    bandwidth_nm: float
    exposure_s: float
    mean_dn: float
    mean_se_dn: float
    dark_dn: float
    dark_se_dn: float
    dark_sigma_dn: float
    frac_at_max: float
    var_dn2: float  # temporal variance of the lit stack (shot noise: ~ K x net signal below saturation)
    pd_light: float
    pd_light_se: float
    pd_dark: float
    pd_dark_se: float


def qe_point(p: SpectralPoint, K: Estimate, table, pd_area_m2: float, pixel_area_m2: float,
             reading: str = "current") -> dict:
    """``{"qe" (%), "mu_p" (photons), "net_signal_dn"}`` as Estimates, plus the relative
    uncertainty budget (``budget``: ``u_calibration``, ``u_gain``, ``u_signal``, ``u_photodiode``,
    each relative) when available.
    ``table``: (wavelengths nm, R A/W, u(R) A/W)."""
    net = p.mean_dn - p.dark_dn
    net_se = math.hypot(p.mean_se_dn, p.dark_se_dn)
    signal = Estimate(net, net_se, "DN", "mu_y - mu_y.dark")

    def na(why: str) -> dict:
        return {"qe": Estimate.na(why, "%"), "mu_p": Estimate.na(why, "photons"), "net_signal_dn": signal}

    rr = responsivity_at(*table, p.wavelength_nm)
    if rr is None:
        return na(f"outside the photodiode's calibration table ({table[0][0]:g}-{table[0][-1]:g} nm)")
    if p.frac_at_max > SATURATED_FRACTION:
        return na(f"saturated ({100 * p.frac_at_max:.2g} % of the pixels at the top code)")
    floor = DARK_SIGMAS * p.dark_sigma_dn
    if not net > floor:  # (first: a dim signal's shot variance is below the scatter of the variance itself,
        #   so the collapse test below would call it saturated by chance)
        return na(f"too dark (net signal {net:.3g} DN below {DARK_SIGMAS:g} dark sigmas, {floor:.3g} DN)")
    shot = p.var_dn2 - p.dark_sigma_dn**2
    if K.available and net > 0 and shot < SHOT_FRACTION * K.value * net:  # full well: the variance collapses
        return na(f"saturated (temporal variance {shot:.3g} DN^2 is below half the shot noise K x signal, "
                  f"{K.value * net:.3g} DN^2: the pixels clip)")
    pd = p.pd_light - p.pd_dark
    if not pd > 0:
        return na("the photodiode read no light above its dark reading")
    r, u_r = rr
    power = pd / r if reading == "current" else pd
    mu_p = photons_per_pixel(power, pd_area_m2, pixel_area_m2, p.exposure_s, p.wavelength_nm)
    rel_pd = math.hypot(p.pd_light_se, p.pd_dark_se) / pd
    rel_cal = u_r / r
    if not K.available:
        return {**na(f"no system gain K ({K.note or 'not measured'})"),
                "mu_p": Estimate(mu_p, mu_p * math.hypot(rel_cal, rel_pd), "photons", "Eq. (3)")}
    rel_k = K.se / K.value if math.isfinite(K.se) else 0.0
    rel_sig = net_se / net
    qe = net / (K.value * mu_p)
    rel = math.sqrt(rel_cal**2 + rel_k**2 + rel_sig**2 + rel_pd**2)
    return {"qe": Estimate(100 * qe, 100 * qe * rel, "%", "Eq. (82)"),
            "mu_p": Estimate(mu_p, mu_p * math.hypot(rel_cal, rel_pd), "photons", "Eq. (3)"),
            "net_signal_dn": signal,
            "budget": {"u_calibration": rel_cal, "u_gain": rel_k, "u_signal": rel_sig, "u_photodiode": rel_pd}}


def mean_se(values) -> tuple[float, float]:
    """Mean of repeated readings and its SE (NaN SE for fewer than 2)."""
    v = [float(x) for x in values]
    m = sum(v) / len(v)
    if len(v) < 2:
        return m, math.nan
    return m, math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1) / len(v))
