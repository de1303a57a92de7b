"""Noise figures of a photon-transfer analysis: read noise (EMVA 1288 4.0 Linear Eqs.
53-54), the absolute sensitivity threshold (Eq. 27), the total-noise model of seed 001
(sensor + shot + PRNU zones) and log-log PTC slopes."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.analysis.ptc.levels import LevelStats
from ares.analysis.stats.median import n_distinct
from ares.analysis.ptc.fit import line_fit

QUANT_VAR = 1.0 / 12.0  # DN^2, uniform quantization noise
QUANT_LIMIT = 0.24  # DN^2, EMVA 1288 4.0 Linear Section 6.6: below this quantization dominates
# the two read-noise figures differ by definition: the one in DN keeps the quantization noise
DARK_NOISE_DEF = "sigma_y.dark: dark temporal noise at the output, quantization noise (1/12 DN^2) included"
READ_NOISE_DEF = ("sigma_d: read noise in e-, quantization noise removed, sqrt(sigma_y.dark^2 - 1/12)/K "
                  "(EMVA 1288 4.0 Linear Eq. 53) -- not sigma_y.dark/K")
QUANT_FLOOR_DN = 0.49  # DN, the sigma_y.dark set in its place (Eq. 54: sigma_d < 0.40 / K)


def read_noise(dark: Sequence[LevelStats], exposure_s: Sequence[float] | None,
               gain: Estimate) -> tuple[Estimate, Estimate, bool]:
    """sigma_y.dark (DN, intercept at t=0 when >= 3 exposures) and read noise in e-."""
    # the same dark level may serve several bright levels: count each once -- by its numbers,
    # not its identity (a run's stages each carry their own copy of a reused matched dark: 25
    # copies counted 25 times made the weighted mean's SE 5x too small)
    seen: dict[tuple, int] = {}
    for i, d in enumerate(dark):
        seen.setdefault((d.mean, d.var, d.n_pixels, d.n_frames), i)
    keep = sorted(seen.values())
    dark = [dark[i] for i in keep]
    v = np.array([d.var for d in dark], float)
    se = np.array([d.var_se for d in dark], float)
    t = None if exposure_s is None else np.asarray(exposure_s, float)[keep]
    if not (np.all(np.isfinite(v)) and np.all(se > 0)):
        why = "no dark temporal variance (dark levels missing, zero or non-finite)"
        return Estimate.na(why, "DN"), Estimate.na(why, "e-"), False
    if t is not None and n_distinct(t) >= 3:
        lf = line_fit(t, v)
        s2, s2_se, how = lf.intercept, lf.intercept_se, "intercept of dark variance vs exposure"
    else:
        w = 1.0 / se**2
        s2 = float(np.sum(w * v) / np.sum(w))
        s2_se = float(math.sqrt(1.0 / np.sum(w)))
        if v.size > 1:
            s2_se = max(s2_se, float(np.std(v, ddof=1) / math.sqrt(v.size)))
        how = "mean dark temporal variance"
    upper = s2 < QUANT_LIMIT
    if upper:  # EMVA 1288 4.0 Linear Eq. 54: sigma_y.dark set to 0.49 DN, sigma_d < 0.40/K
        note = (f"upper limit: sigma_y.dark^2 = {s2:.2g} DN^2 < 0.24 DN^2, quantization dominates "
                "(EMVA 1288 4.0 Linear Eq. 54)")
        dn = Estimate.limit(QUANT_FLOOR_DN, "upper", "DN", note)
        if not gain.available:
            return dn, Estimate.na("gain not available", "e-"), True
        val = math.sqrt(QUANT_FLOOR_DN**2 - QUANT_VAR) / gain.value
        return dn, Estimate.limit(val, "upper", "e-", note), True
    dn = Estimate(math.sqrt(s2), s2_se / (2 * math.sqrt(s2)), "DN", f"{DARK_NOISE_DEF}; {how}")
    if not gain.available:
        return dn, Estimate.na("gain not available", "e-"), False
    num = math.sqrt(max(s2 - QUANT_VAR, 0.0))
    val = num / gain.value
    d_s2 = s2_se / (2 * num) / gain.value if num > 0 else math.nan
    se_e = math.hypot(d_s2, val * gain.se / gain.value)
    return dn, Estimate(val, se_e, "e-", f"{READ_NOISE_DEF}; {how}"), False


def sensitivity_threshold(read_noise_dn: Estimate, gain: Estimate) -> Estimate:
    """EMVA 1288 4.0 Linear Eq. 27: ``mu_e.min = sqrt(sigma_y.dark^2/K^2 + 1/4) + 1/2`` (e-),
    with sigma_y.dark in DN *including* quantization noise (the exact form; not sigma_d)."""
    if not read_noise_dn.available or not gain.available:
        return Estimate.na("needs the dark noise and the gain", "e-")
    a = read_noise_dn.value / gain.value
    root = math.sqrt(a * a + 0.25)
    val = root + 0.5
    if read_noise_dn.bound:
        return Estimate.limit(val, read_noise_dn.bound, "e-", "SNR = 1 (EMVA 1288 4.0 Eq. 27) from " + read_noise_dn.note)
    se_a = a * math.hypot(read_noise_dn.se / read_noise_dn.value if math.isfinite(read_noise_dn.se) else 0.0,
                          gain.se / gain.value if math.isfinite(gain.se) else 0.0)
    return Estimate(val, a / root * se_a if se_a else math.nan, "e-", "SNR = 1 (EMVA 1288 4.0 Linear Eq. 27)")


def noise_model(good: Sequence[PtcLevel], dark: Sequence[LevelStats], gain: Estimate):
    """Fit sigma_total^2 = sigma_sensor^2 + N_e + (PRNU * N_e)^2 (all in e-), where
    sigma_total^2 = bright temporal + spatial variance. Returns (fit, zones)."""
    if not gain.available or len(good) < 3:
        return {}, {}
    k = gain.value
    rows = [(lv.signal / k, (lv.total_var + lv.spatial_var) / k**2) for lv in good
            if math.isfinite(lv.spatial_var)]
    if len(rows) < 3:
        return {}, {}
    ne, tot = np.array(rows).T
    y = tot - ne
    A = np.vstack([np.ones_like(ne), ne**2]).T
    # weights: relative error of a variance ~ sqrt(2/N); use 1/tot
    w = 1.0 / tot
    coef, *_ = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)
    r = (y - A @ coef) * w
    dof = max(len(y) - 2, 1)
    cov = np.linalg.inv((A * w[:, None]).T @ (A * w[:, None])) * float(r @ r) / dof
    se = np.sqrt(np.diag(cov))
    s2r, p2 = coef
    out = {}
    if s2r > 0:
        out["sensor_noise_e"] = Estimate(math.sqrt(s2r), se[0] / (2 * math.sqrt(s2r)), "e-",
                                         "dark temporal + DSNU, from the total-noise model")
    else:
        out["sensor_noise_e"] = Estimate.na("fitted sensor variance <= 0", "e-")
    if p2 > 0:
        out["prnu_pct"] = Estimate(100 * math.sqrt(p2), 100 * se[1] / (2 * math.sqrt(p2)), "%",
                                   "total-noise model; includes illumination non-uniformity (no high-pass)")
    else:
        out["prnu_pct"] = Estimate.na("fitted PRNU^2 <= 0", "%")
    zones = {}
    if out["sensor_noise_e"].available:
        zones["read_to_shot_e"] = Estimate(s2r, se[0], "e-", "N_e where shot noise equals the sensor noise")
    if out["prnu_pct"].available:
        zones["shot_to_prnu_e"] = Estimate(1 / p2, se[1] / p2**2, "e-", "N_e where PRNU noise equals shot noise")
    return out, zones


def loglog_slopes(signal, noise) -> np.ndarray:
    """Local slopes of log(noise) vs log(signal): ~0 read floor, 1/2 shot, 1 PRNU."""
    s = np.asarray(signal, float)
    n = np.asarray(noise, float)
    ok = (s > 0) & (n > 0)
    return np.gradient(np.log(n[ok]), np.log(s[ok])) if ok.sum() >= 2 else np.array([])
