"""EMVA 1288 Release 4.0 General: the whole of its Table 2 (General Section 10), in photon units.

``complete`` adds to a ``GeneralResult`` every Table 2 entry ``emva_general`` does not compute
itself, so that each is a value with its SE or verdict, or "not available" with the reason:

* QE, K and 1/K: "cannot be measured" (General Table 2; Section 6.7, "Overall system gain K"
  and "Quantum efficiency");
* 1/SNR_max in %, mu_p.min and mu_p.sat per um^2 (pixel area given);
* DSNU1288 and PRNU1288 with their .row/.col/.pix parts in photons (Section 8, Eqs. 55 -
  59): the spatial variances of the averaged dark and ~50 % images (the Linear split,
  Eqs. 36 - 44, as written) carried to the input by the slope of the characteristic curve
  (Eq. 56) -- R_d at zero exposure, the slope at mu_p.50 for the bright image;
* the linearity error LE (Linear Eqs. 59 - 63 on the characteristic curve) if the curve is
  linear by the Linear Eq. 51 check, otherwise the statement that it is not;
* the total input SNR per step (Eq. 60, ``GeneralResult.snr_p_total``);
* dark current from the mean and from the variance in photons/s (Section 7.1: the slopes
  over the exposure time divided by R_d and R_d^2), as value +- its one-sigma error; a rate
  not above its error also gets the upper limit mu_I + sigma_I (``*_upper``).

Pure numpy: no I/O.
"""

from __future__ import annotations

import math

import numpy as np

from ares.analysis.emva.sanity import judge
from ares.analysis.stats.estimate import EXACT_PHOTONS_AREA, Estimate

# Table 2 of the General document: (key, printed symbol, unit)
GENERAL_TABLE2 = (
    ("QE", "η", "%"), ("K", "K", "DN/e-"), ("K_inv", "1/K", "e-/DN"),
    ("sigma_y_dark", "σy.dark", "DN"), ("sigma_d", "σd", "photons"),
    ("SNR_max", "SNRp.max", ""), ("SNR_max_db", "SNRp.max", "dB"), ("SNR_max_inv", "1/SNRp.max", "%"),
    ("mu_p_min", "µp.min", "photons"), ("mu_p_min_area", "µp.min.area", "photons/µm²"),
    ("mu_p_sat", "µp.sat", "photons"), ("mu_p_sat_area", "µp.sat.area", "photons/µm²"),
    ("DR", "DR", ""), ("DR_db", "DR", "dB"),
    ("DSNU1288", "DSNU1288", "photons"), ("DSNU1288_row", "DSNU1288.row", "photons"),
    ("DSNU1288_col", "DSNU1288.col", "photons"), ("DSNU1288_pix", "DSNU1288.pix", "photons"),
    ("PRNU1288", "PRNU1288", "%"), ("PRNU1288_row", "PRNU1288.row", "%"),
    ("PRNU1288_col", "PRNU1288.col", "%"), ("PRNU1288_pix", "PRNU1288.pix", "%"),
    ("LE", "LE", "%"), ("mu_I_mean", "µI.mean", "photons/s"), ("mu_I_var", "µI.var", "photons/s"),
)
CANNOT = {"QE": "Section 6.7, 'Quantum efficiency': the general model has no gain to divide R by",
          "K": "Section 6.7, 'Overall system gain K': not estimable with the general model",
          "K_inv": "Section 6.7, 'Overall system gain K': not estimable with the general model"}


def cannot_be_measured(key: str, unit: str) -> Estimate:
    return Estimate.na(f"cannot be measured (EMVA 1288 4.0 General, Table 2; {CANNOT[key]})", unit)


def _per_area(e: Estimate, area: float | None, unit: str) -> Estimate:
    if not area:
        return Estimate.na("pixel size not given (--pixel-size-um)", unit)
    if not e.available:
        return Estimate.na(e.note, unit)
    note = f"{e.note}; / pixel area ({area:g} µm²)"
    if e.is_exact:  # declared photons over the declared pixel area: exact too
        return Estimate.declared(e.value / area, unit, EXACT_PHOTONS_AREA, note)
    return Estimate.limit(e.value / area, e.bound, unit, note) if e.bound else \
        Estimate(e.value / area, e.se / area, unit, note)


PHOTON_COUNT_TOLERANCE = 0.10  # the bright stack's signal against the curve at its declared photons


def photon_count_mismatch(stack_bright, stack_dark, curve) -> str:
    """Why the bright stack's declared photons cannot be used (its signal is not what the
    set's own characteristic curve gives at them, beyond ``PHOTON_COUNT_TOLERANCE``), or ""."""
    if curve is None or stack_bright is None or stack_dark is None or not stack_bright.photons > 0:
        return ""
    sig = float(np.mean(stack_bright.mean_image) - np.mean(stack_dark.mean_image))
    want = float(curve(float(stack_bright.photons)))
    if not (want > 0 and sig > 0) or abs(sig / want - 1) <= PHOTON_COUNT_TOLERANCE:
        return ""
    return (f"inconsistent photon counts: the bright stack's signal {sig:.4g} DN is {sig / want:.3g}x what the set's "
            f"own characteristic curve gives at its declared {stack_bright.photons:.4g} photons ({want:.4g} DN); "
            "its nonuniformity in photons would be off by as much")


def _nonuniformity(v: dict, res, stack_dark, stack_bright) -> None:
    """DSNU1288 (Eq. 58) and PRNU1288 (Eq. 59) with their parts, in photons."""
    from ares.analysis.spatial.nonuniformity import PARTS, std_estimate

    rd = v.get("R_d", Estimate.na("no characteristic curve"))
    keys = [("DSNU1288" + s.replace(".", "_"), "photons") for _, s in PARTS] + \
           [("PRNU1288" + s.replace(".", "_"), "%") for _, s in PARTS]
    why = ("no dark stack (averaged dark images, General Section 8)" if stack_dark is None else
           "R_d not available: " + rd.note if not (rd.available and rd.value > 0) else "")
    if why:
        for k, u in keys:
            v[k] = Estimate.na(why, u)
        return
    try:
        ds = stack_dark.split("4.0")
        hp = "after the high-pass of Section 8.1"
    except ValueError as exc:
        ds, hp = stack_dark.split("none"), f"without the high-pass ({exc})"
    r, r_rel = rd.value, rd.se / rd.value
    s2, se2 = ds.get("total")  # General Section 8.3: DSNU1288 in photons and also in DN
    v["DSNU1288_DN"] = std_estimate(s2, se2, 1.0, 0.0, "DN", f"s_y.dark (General Section 8.3), {hp}",
                                    ds.bias_of("total"))
    for part, suffix in PARTS:
        s2, se2 = ds.get(part)
        v["DSNU1288" + suffix.replace(".", "_")] = std_estimate(
            s2, se2, 1.0 / r, r_rel, "photons", f"s_y.dark{suffix} / R_d (EMVA 1288 4.0 General Eqs. 56, 58), {hp}",
            ds.bias_of(part))
    mu_p50 = float(stack_bright.photons) if stack_bright is not None else math.nan
    if stack_bright is None or not mu_p50 > 0 or res.curve is None:
        why = "no bright stack (averaged images at ~50 % saturation) with its photons" if stack_bright is None or \
            not mu_p50 > 0 else "no characteristic curve"
        for k, u in keys[4:]:
            v[k] = Estimate.na(why, u)
        return
    why = photon_count_mismatch(stack_bright, stack_dark, res.curve)
    if why:
        for k, u in keys[4:]:
            v[k] = Estimate.na(why, u)
        return
    bs = stack_bright.split("4.0" if hp.startswith("after") else "none")
    slope = float(res.curve.slope(mu_p50))  # Eq. 56: variances to the input by the local slope
    slope_rel = float(res.curve.se(mu_p50, derivative=True)) / slope if slope > 0 else math.nan
    for part, suffix in PARTS:
        key = "PRNU1288" + suffix.replace(".", "_")
        if not slope > 0:
            v[key] = Estimate.na("the characteristic curve does not rise at mu_p.50", "%")
            continue
        b, bse = bs.get(part)
        d, dse = ds.get(part)
        s2p = b / slope**2 - d / r**2  # s2_p.50 - s2_p.dark (Eq. 59)
        se2p = math.hypot(bse / slope**2, dse / r**2)
        e = std_estimate(s2p, se2p, 100.0 / mu_p50, 0.0, "%",
                          f"sqrt(s2_p.50{suffix} - s2_p.dark{suffix}) / mu_p.50 (General Eqs. 55, 56, 59), {hp}",
                          bs.bias_of(part) / slope**2 - ds.bias_of(part) / r**2)
        if e.available and not e.bound:  # the slopes' errors (a common scale of each variance)
            e = Estimate(e.value, math.hypot(e.se, e.value * math.hypot(b / slope**2 * slope_rel, d / r**2 * r_rel)
                                             / max(s2p, 1e-300)), e.unit, e.note)
        v[key] = e


def _linearity(v: dict, res, linear) -> None:
    from ares.analysis.emva.linear import LE_RANGE, linearity_error

    if res.index_sat is None:
        v["LE"] = Estimate.na("saturation not found: the 5 - 95 % range cannot be set", "%")
        return
    y_sat = float(res.signal[res.index_sat])
    lo, hi = LE_RANGE
    li = np.flatnonzero((res.signal >= lo * y_sat) & (res.signal <= hi * y_sat) & (res.photons > 0))
    if li.size < 3:
        v["LE"] = Estimate.na(f"needs >= 3 levels between 5 and 95 % of saturation, has {li.size}", "%")
        return
    le, le_se, _ = linearity_error(res.signal[li], res.photons[li])
    holds = None if linear is None else linear.linear
    if holds is True:
        v["LE"] = Estimate(le, le_se, "%", "the characteristic curve is linear (Linear Eq. 51 holds): LE by Linear "
                                           "Eqs. 59 - 63, 5 - 95 % of saturation")
    elif holds is False:
        v["LE"] = Estimate.na("nonlinear characteristic curve (Linear Eq. 51 fails: "
                              f"{linear.linear_check.note if linear.linear_check else ''}); General Table 2 asks for "
                              f"the type of nonlinearity, which ARES does not classify (LE would read {le:.3g} %)", "%")
    else:
        v["LE"] = Estimate.na(f"linearity not decided (no Linear Eq. 51 check); LE would read {le:.3g} %", "%")


def _dark_current(v: dict, dark, texp, dark_series, linear=None) -> None:
    """mu_I.p = mu_I.y / R_d from the dark mean's slope (General Eqs. 22, 24, 25). From the
    variance's slope (Eq. 23) the photons need K as well: the variance grows by K^2 per
    electron, R_d = K eta, so photons/s = slope / (K R_d) (dividing by R_d^2 would divide by
    eta^2 where eta belongs); K is not defined by the General model, so it comes from the
    Linear evaluation of the same data, or the figure is not available."""
    from ares.analysis.ptc.dark_current import dark_current, with_upper_limit

    rd = v.get("R_d", Estimate.na("no characteristic curve"))
    if dark_series is not None:
        t, mu, s2 = dark_series
    elif texp is not None:
        t, mu, s2 = texp, np.array([x.mean for x in dark]), np.array([x.var for x in dark])
    else:
        for k in ("mu_I_mean", "mu_I_var"):
            v[k] = Estimate.na("no exposure times given", "photons/s")
        return
    dc = dark_current(t, mu, rd, s2)
    k = linear.values.get("K") if linear is not None else None
    if k is not None and k.available and rd.available and k.value > 0 and rd.value > 0:
        g = math.sqrt(k.value * rd.value)  # slope / g^2 = slope / (K R_d)
        gse = 0.5 * g * math.hypot(k.se / k.value if math.isfinite(k.se) else 0.0,
                                   rd.se / rd.value if math.isfinite(rd.se) else 0.0)
        var_e = dark_current(t, mu, Estimate(g, gse, "DN/e-"), s2).rate_from_variance_e_per_s
        var_div = "(K R_d), K from the Linear evaluation"
    else:
        var_e = Estimate.na("from the variance it needs the system gain K (photons/s = slope / (K R_d)), which "
                            "the General model does not define and no Linear evaluation gave (General Section 3.1)",
                            "photons/s")
        var_div = ""
    for key, e, div in (("mu_I_mean", dc.rate_e_per_s, "R_d"), ("mu_I_var", var_e, var_div)):
        if e.available:
            e = Estimate(e.value, e.se, "photons/s", f"slope over the exposure time / {div} (EMVA 1288 4.0 General "
                                                     "Eqs. 22 - 25, Section 7.1)") if not e.bound else \
                Estimate.limit(e.value, e.bound, "photons/s", e.note)
        else:
            e = Estimate.na(e.note, "photons/s")
        v.update(with_upper_limit(key, e))


def total_snr(res, step_spatial_var) -> "np.ndarray":
    """Eq. 60: SNR_p.total = mu_p / sqrt(sigma_p^2 + s_p^2) per step, the temporal and the
    spatial variance of the output (``step_spatial_var``, DN^2, sorted as ``res.photons``)
    carried to the input by the local slope of the characteristic curve (Eq. 56); NaN where
    the slope is not positive."""
    out = np.full(res.photons.size, np.nan)
    if res.curve is None:
        return out
    slope = res.curve.slope(res.photons)
    s2 = np.asarray(step_spatial_var, float)
    ok = (slope > 0) & (res.photons > 0) & np.isfinite(s2)
    out[ok] = res.photons[ok] * slope[ok] / np.sqrt(res.sigma_y[ok] ** 2 + np.maximum(s2[ok], 0.0))
    return out


def complete(res, dark, texp, *, stack_dark=None, stack_bright=None, dark_series=None,
             pixel_area_um2: float | None = None, linear=None, step_spatial_var=None) -> None:
    """Fill ``res.values`` with the whole General Table 2 (module docstring), in its order,
    followed by what else was computed (R_d, the upper-limit readings). ``dark`` and
    ``texp``: the darks and exposure times of the steps, sorted as ``res.photons``;
    ``linear``: the Linear evaluation of the same data (its Eq. 51 check decides LE)."""
    v = res.values
    for k in CANNOT:
        v[k] = cannot_be_measured(k, dict((a, c) for a, _, c in GENERAL_TABLE2)[k])
    s = v.get("SNR_max", Estimate.na("", ""))
    v["SNR_max_inv"] = (Estimate.na(s.note, "%") if not s.available else
                        Estimate.limit(100 / s.value, "upper" if s.bound == "lower" else "lower", "%", "1 / SNR_p.max")
                        if s.bound else Estimate(100 / s.value, 100 * s.se / s.value**2, "%", "1 / SNR_p.max"))
    for key in ("mu_p_min", "mu_p_sat"):
        v[key + "_area"] = _per_area(v.get(key, Estimate.na("not computed", "photons")), pixel_area_um2,
                                     "photons/µm²")
    _nonuniformity(v, res, stack_dark, stack_bright)
    _linearity(v, res, linear)
    _dark_current(v, dark, texp, dark_series, linear)
    if step_spatial_var is not None:
        res.snr_p_total = total_snr(res, step_spatial_var)
    for k, _, u in GENERAL_TABLE2:
        v.setdefault(k, Estimate.na("not computed: too few levels for the characteristic curve", u))
    tx = dark_series[0] if dark_series is not None else texp
    v = judge(v, saturation=v.get("mu_p_sat"), longest_exposure_s=float(np.max(tx)) if tx is not None and np.size(tx)
              else None)
    order = [k for k, _, _ in GENERAL_TABLE2]
    res.values = {**{k: v[k] for k in order}, **{k: e for k, e in v.items() if k not in order}}
