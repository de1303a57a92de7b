"""Dark current against temperature, for the frame and per pixel.

- Frame: ``I(T) = I_0 2^(T / T_d)`` -- a line of log2 I against T (``ares.analysis.ptc.dark_current.
  doubling_temperature``, here with the reference at 0 C) -- and the Arrhenius law
  ``I = A exp(-E_a / kT)``, a line of ln I against 1/kT.
- Per pixel: the Arrhenius line of every pixel at once (weighted by the rates' SEs when given,
  else by the pixel's own residual scatter), E_a and ln A maps with SEs, the local doubling
  temperature ``T_d = ln 2 k T^2 / E_a``; the regime of each pixel by its E_a (depletion: near
  half the band gap, generation at mid-gap states; diffusion: near the band gap, 1.12 eV;
  below 0.45 eV field-enhanced, the signature of a hot pixel); pixels whose E_a is below the
  bulk's median by more than ``min_drop_ev`` and 5 of their SEs are "hot by activation energy".
- Meyer-Neldel: ``ln A = ln A_00 + E_a / E_MN`` across pixels (E_MN the Meyer-Neldel energy,
  ``T_iso = E_MN / k`` the isokinetic temperature). The per-pixel fit errors of ln A and E_a are
  themselves correlated along a line of slope 1 / (k T_mean) (the compensation artefact), so
  a Meyer-Neldel energy near k T_mean is stated beside that artefact's value, not as physics
  alone (Widenhorn et al. 2002 on CCDs; the issue's 222 000-pixel CCD at 0.633 eV bulk E_a).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.analysis.ptc.dark_current import doubling_temperature

K_B_EV = 8.617333262e-5  # Boltzmann constant, eV/K
T0_K = 273.15
EG_SI_EV = 1.12  # silicon band gap near room temperature
REGIMES = (("field_enhanced", 0.0, 0.45), ("depletion", 0.45, 0.85), ("diffusion", 0.85, math.inf))


def _x(temperature_c) -> np.ndarray:
    return 1.0 / (K_B_EV * (np.asarray(temperature_c, np.float64) + T0_K))


def frame_fit(temperature_c, rate, rate_se=None, ref_c: float = 0.0, unit: str = "e-/s") -> dict[str, Estimate]:
    """The frame's dark current against temperature: rate at ``ref_c`` and doubling temperature
    (log2-linear), Arrhenius activation energy and ln prefactor (SEs from the weights when given,
    else from the scatter)."""
    T = np.asarray(temperature_c, np.float64)
    r = np.asarray(rate, np.float64)
    se = None if rate_se is None else np.asarray(rate_se, np.float64)
    ok = np.isfinite(T) & np.isfinite(r) & (r > 0) & (True if se is None else np.isfinite(se) & (se > 0))
    d = doubling_temperature(T[ok], r[ok], None if se is None else se[ok], ref_c=ref_c)
    out = {"doubling_c": d.doubling_c,
           "rate_at_ref": Estimate(d.value_at_ref.value, d.value_at_ref.se, unit, f"rate at {ref_c:g} C")
           if d.value_at_ref.available else Estimate.na(d.value_at_ref.note, unit)}
    if ok.sum() < 3:
        na = "needs >= 3 temperatures with a positive rate"
        out.update(activation_ev=Estimate.na(na, "eV"), ln_prefactor=Estimate.na(na))
        return out
    x, y = _x(T[ok]), np.log(r[ok])
    w = np.ones_like(y) if se is None else (r[ok] / se[ok]) ** 2
    ea, ea_se, la, la_se, chi2, _c = _wls(x[:, None], y[:, None], w[:, None], se is not None)
    note = "slope of ln I vs 1/kT" + (" (weighted by the rates' SEs)" if se is not None else " (unweighted)")
    out.update(activation_ev=_physical(Estimate(float(ea[0]), float(ea_se[0]), "eV", note)),
               ln_prefactor=Estimate(float(la[0]), float(la_se[0]), f"ln({unit})", "intercept of ln I at 1/kT = 0"),
               )
    if se is not None:  # chi-square per degree of freedom against the rates' SEs
        out["chi2_dof"] = float(chi2[0])
    else:  # no SEs: no chi-square -- the rms scatter of ln I about the line (w = 1), named so
        out["ln_rate_scatter"] = float(math.sqrt(chi2[0]))
    return out


def _physical(e: Estimate) -> Estimate:
    if e.available and not 0 < e.value < 3 * EG_SI_EV:
        return Estimate.na(f"activation energy {e.value:.3g} eV is outside 0 .. {3 * EG_SI_EV:g} eV: the rate does "
                           "not grow with temperature as a thermal generation does", "eV")
    return e


def _wls(x, y, w, absolute: bool):
    """Per column of y (n_T, n): weighted line of y against x (n_T, 1). Returns (E_a = -slope,
    its SE, intercept, its SE, chi2/dof, covariance of E_a and the intercept); SEs absolute when ``absolute`` (w = 1/sigma^2), else
    from the scatter."""
    S = w.sum(0)
    Sx = (w * x).sum(0)
    Sy = (w * y).sum(0)
    Sxx = (w * x * x).sum(0)
    Sxy = (w * x * y).sum(0)
    D = S * Sxx - Sx * Sx
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = (S * Sxy - Sx * Sy) / D
        icpt = (Sxx * Sy - Sx * Sxy) / D
        res = y - (icpt + slope * x)
        dof = np.maximum(y.shape[0] - 2, 1)
        chi2 = (w * res * res).sum(0) / dof
        scale = np.ones_like(chi2) if absolute else chi2
        if y.shape[0] < 3 and not absolute:
            scale = np.full_like(chi2, np.nan)
        slope_se = np.sqrt(S / D * scale)
        icpt_se = np.sqrt(Sxx / D * scale)
        cov = Sx / D * scale  # cov(-slope, intercept)
    return -slope, slope_se, icpt, icpt_se, chi2, cov


@dataclass
class PixelArrhenius:
    activation_ev: np.ndarray  # (R, C), NaN where not available
    activation_se_ev: np.ndarray
    ln_prefactor: np.ndarray  # ln(A / (e-/s))
    ln_prefactor_se: np.ndarray
    chi2_dof: np.ndarray
    cov: np.ndarray  # covariance of the E_a and ln A estimates (eV)
    valid: np.ndarray  # bool: every temperature's rate positive and finite
    temperatures_c: np.ndarray

    def doubling_c(self, at_c: float) -> np.ndarray:
        """Local doubling temperature of each pixel at ``at_c``: ln 2 k T^2 / E_a."""
        t = at_c + T0_K
        with np.errstate(divide="ignore", invalid="ignore"):
            return math.log(2) * K_B_EV * t * t / self.activation_ev


def pixel_fit(temperature_c, rates, rates_se=None) -> PixelArrhenius:
    """``rates`` (n_T, R, C) in any unit (e-/s or DN/s: E_a does not depend on it), ``rates_se``
    the same shape or None."""
    T = np.asarray(temperature_c, np.float64)
    r = np.asarray(rates, np.float64)
    shape = r.shape[1:]
    r2 = r.reshape(r.shape[0], -1)
    valid = np.all(np.isfinite(r2) & (r2 > 0), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.log(np.where(valid[None, :], r2, 1.0))
        if rates_se is not None:
            s = np.asarray(rates_se, np.float64).reshape(r2.shape)
            valid &= np.all(np.isfinite(s) & (s > 0), axis=0)
            w = np.where(valid[None, :], (r2 / s) ** 2, 1.0)
        else:
            w = np.ones_like(y)
    ea, ea_se, la, la_se, chi2, cov = _wls(_x(T)[:, None], y, w, rates_se is not None)
    if rates_se is not None:
        s = np.asarray(rates_se, np.float64).reshape(r2.shape)
        valid = np.all(np.isfinite(r2) & np.isfinite(s) & (s > 0), axis=0)
        ea, ea_se, la, la_se, chi2, cov, ok = _rate_fit(_x(T), r2, np.where(valid[None, :], s, 1.0), ea, la)
        valid &= ok
    nan = lambda a: np.where(valid, a, np.nan).reshape(shape)
    return PixelArrhenius(nan(ea), nan(ea_se), nan(la), nan(la_se), nan(chi2), nan(cov), valid.reshape(shape), T)


def _rate_fit(x, r, s, ea0, la0, iterations: int = 12):
    """Per pixel, ``r = exp(la - ea x)`` fitted to the rates themselves with w = 1/s^2 (Gauss-
    Newton, all pixels at once): the line of ln r weighted by (r/s)^2 takes its weights from
    the noisy rates (a rate that fell low weighs less) and drops every pixel with a rate <= 0,
    both biasing E_a low at few frames (issue 48: the shipped dark_temperature scan's median
    E_a 8 - 37 SE below the simulator's at 2 - 16 frames, "ok"). Starts from the log line
    where it exists, else from the median pixel's E_a with the amplitude solved. Returns
    (E_a, SE, ln A, SE, chi2/dof, cov(E_a, ln A), converged)."""
    n_t, n = r.shape
    w = 1.0 / (s * s)
    xc = x[:, None]
    good0 = np.isfinite(ea0) & np.isfinite(la0) & np.all(r > 0, axis=0)
    ea = np.where(good0, ea0, np.nanmedian(np.where(good0, ea0, np.nan)) if good0.any() else 0.6)
    m0 = np.exp(-ea[None, :] * (xc - x.mean()))
    with np.errstate(divide="ignore", invalid="ignore"):
        amp = (w * m0 * r).sum(0) / (w * m0 * m0).sum(0)  # the amplitude at that E_a, closed form
        la = np.where(good0, la0, np.log(np.where(amp > 0, amp, np.nan)) + ea * x.mean())
    ok = np.isfinite(la) & np.isfinite(ea)
    la, ea = np.where(ok, la, 0.0), np.where(ok, ea, 0.0)
    for _ in range(iterations):
        with np.errstate(over="ignore", invalid="ignore"):
            m = np.exp(la[None, :] - ea[None, :] * xc)
            res = r - m
            a = (w * m * m).sum(0)
            b = -(w * xc * m * m).sum(0)
            c = (w * xc * xc * m * m).sum(0)
            g1 = (w * m * res).sum(0)
            g2 = -(w * xc * m * res).sum(0)
            det = a * c - b * b
            dla = (c * g1 - b * g2) / det
            dea = (a * g2 - b * g1) / det
        step = np.isfinite(dla) & np.isfinite(dea)
        dea = np.clip(np.where(step, dea, 0.0), -0.2, 0.2)  # (no step beyond 0.2 eV at once)
        dla = np.clip(np.where(step, dla, 0.0), -5.0, 5.0)
        la, ea = la + dla, ea + dea
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        m = np.exp(la[None, :] - ea[None, :] * xc)
        res = r - m
        a = (w * m * m).sum(0)
        b = -(w * xc * m * m).sum(0)
        c = (w * xc * xc * m * m).sum(0)
        det = a * c - b * b
        chi2 = (w * res * res).sum(0) / max(n_t - 2, 1)
        ea_se, la_se, cov = np.sqrt(a / det), np.sqrt(c / det), -b / det
    ok &= np.isfinite(ea_se) & np.isfinite(la_se) & (det > 0) & (np.abs(dea) < 1e-6 + 1e-4 * np.abs(ea))
    return ea, ea_se, la, la_se, chi2, cov, ok


def _mn_slope(ea, la, var_ea, cov):
    """Slope of ln A on E_a across pixels with the fit errors' share taken out (moments:
    (cov(E_a, ln A) - mean fit covariance) / (var(E_a) - mean fit variance))."""
    c = float(np.mean((ea - ea.mean()) * (la - la.mean()))) - float(np.mean(cov))
    v = float(np.var(ea)) - float(np.mean(var_ea))
    return c / v if v > 0 else math.nan


def meyer_neldel(fit: PixelArrhenius, min_pixels: int = 10, blocks: int = 20) -> dict[str, Estimate]:
    """``ln A = ln A_00 + E_a / E_MN`` across the pixels with an E_a measured to better than a
    quarter of itself: E_MN (eV) and the isokinetic temperature (K), the slope's share from the
    per-pixel fit errors removed (their covariance is known from each fit); SE by a jackknife
    over ``blocks`` blocks of pixels. ``artefact_ev``: the E_MN the fit errors alone would give
    (k T at the scan's mean 1/kT), and ``naive_ev`` the plain regression's."""
    ea, la, se = fit.activation_ev.ravel(), fit.ln_prefactor.ravel(), fit.activation_se_ev.ravel()
    cov = fit.cov.ravel()
    ok = np.isfinite(ea) & np.isfinite(la) & np.isfinite(cov) & (se < 0.25 * np.abs(ea))
    tmean = 1.0 / (K_B_EV * float(np.mean(_x(fit.temperatures_c))))
    artefact = Estimate.declared(K_B_EV * tmean, "eV", "k T of the set temperatures",
                                 "k T at the scan's mean 1/kT: the E_MN the fit errors alone give")
    base = {"artefact_ev": artefact, "t_mean_k": tmean}
    if ok.sum() < max(min_pixels, 2 * blocks) or np.ptp(ea[ok]) == 0:
        na = f"needs >= {max(min_pixels, 2 * blocks)} pixels with E_a measured to 25 %, got {int(ok.sum())}"
        return {"meyer_neldel_ev": Estimate.na(na, "eV"), "isokinetic_k": Estimate.na(na, "K"),
                "naive_ev": Estimate.na(na, "eV"), "pixels": int(ok.sum()), **base}
    x, y, vx, c = ea[ok], la[ok], se[ok] ** 2, cov[ok]
    n = x.size
    b = _mn_slope(x, y, vx, c)
    naive = _naive(x, y)
    idx = np.arange(n) % blocks
    jk = np.array([_mn_slope(x[idx != j], y[idx != j], vx[idx != j], c[idx != j]) for j in range(blocks)])
    b_se = math.sqrt((blocks - 1) / blocks * float(np.sum((jk - jk.mean()) ** 2))) if np.all(np.isfinite(jk)) else math.nan
    nv = np.array([_naive(x[idx != j], y[idx != j]) for j in range(blocks)])  # (its SE: the same jackknife)
    naive_se = math.sqrt((blocks - 1) / blocks * float(np.sum((nv - nv.mean()) ** 2)))
    note = f"1 / slope of ln A vs E_a over {n} pixels, the fit errors' covariance removed"
    if not (b > 0 and math.isfinite(b_se)) or b_se > b:
        why = ("the pixels' E_a spread is within their fit errors: no slope beyond them" if not b > 0 or b_se > b
               else "the slope has no SE")
        emn = Estimate.na(why, "eV")
    else:
        emn = Estimate(1 / b, b_se / b**2, "eV", note)
    iso = Estimate(emn.value / K_B_EV, emn.se / K_B_EV, "K", "E_MN / k") if emn.available else Estimate.na(emn.note, "K")
    return {"meyer_neldel_ev": emn, "isokinetic_k": iso,
            "naive_ev": Estimate(1 / naive, naive_se / naive**2, "eV", "plain regression, fit errors included")
            if naive > 0 else Estimate.na("ln A does not grow with E_a", "eV"),
            "pixels_mn": int(n), **base}


def _naive(x, y) -> float:
    """The plain regression's slope of ``y`` on ``x`` (no errors-in-variables correction)."""
    return float(np.mean((x - x.mean()) * (y - y.mean()))) / float(np.var(x))


def regimes(fit: PixelArrhenius) -> dict[str, int]:
    """Pixels per regime of E_a (``REGIMES``: field_enhanced < 0.45 eV <= depletion < 0.85 eV <= diffusion)."""
    ea = fit.activation_ev[np.isfinite(fit.activation_ev)]
    return {name: int(np.sum((ea >= lo) & (ea < hi))) for name, lo, hi in REGIMES}


def hot_by_activation(fit: PixelArrhenius, min_drop_ev: float = 0.05, n_se: float = 5.0,
                      n_spread: float = 5.0) -> np.ndarray:
    """Pixels whose E_a is below the bulk's median by more than ``min_drop_ev``, ``n_spread``
    robust SDs of the bulk's E_a (1.4826 MAD) and ``n_se`` of their own SEs (bool map): outside
    the bulk's distribution, not its tail."""
    ea = fit.activation_ev
    good = ea[np.isfinite(ea)]
    if good.size == 0:
        return np.zeros(ea.shape, bool)
    med = float(np.median(good))
    spread = 1.4826 * float(np.median(np.abs(good - med)))
    drop = med - ea
    with np.errstate(invalid="ignore"):
        return (np.isfinite(ea) & (drop > min_drop_ev) & (drop > n_spread * spread)
                & (drop > n_se * fit.activation_se_ev))


def summarize(fit: PixelArrhenius, at_c: float = 0.0, common_se_ev: float = 0.0) -> dict:
    """The maps' figures: median E_a and its spread, median doubling temperature at ``at_c``,
    regimes, hot-by-E_a count, Meyer-Neldel. ``common_se_ev``: the error every pixel's E_a
    shares (the frame-wide temporal terms -- frame offset, row and column noise -- move all
    pixels' rates at a temperature together), e.g. the frame's Arrhenius fit's SE on the
    frame means' measured scatter: added to the median's, which the pixels' spread alone gives
    (issue 48: without it the shipped dark_temperature scan's median E_a was 4 - 18 SE from the
    simulator's at 16 frames, "ok")."""
    ea = fit.activation_ev[np.isfinite(fit.activation_ev)]
    se = fit.activation_se_ev[np.isfinite(fit.activation_ev)]
    n = ea.size
    if n == 0:
        na = "no pixel has a positive rate at every temperature"
        return {"pixels": 0, "median_activation_ev": Estimate.na(na, "eV")}
    med = float(np.median(ea))
    spread = float(np.std(ea, ddof=1)) if n > 1 else math.nan
    noise = float(np.sqrt(np.mean(se * se)))
    td = fit.doubling_c(at_c)
    td = td[np.isfinite(td)]
    return {
        "pixels": int(n),
        "median_activation_ev": Estimate(
            med, math.hypot(1.2533 * spread / math.sqrt(n), common_se_ev) if n > 1 else math.nan, "eV",
            "median of the per-pixel E_a" + (f"; SE: the pixels' spread / sqrt(n) and the error all pixels share "
                                             f"({common_se_ev:.2g} eV, the frame's fit)" if common_se_ev > 0 else "")),
        "activation_spread_ev": Estimate(spread, spread / math.sqrt(2 * (n - 1)) if n > 1 else math.nan, "eV",
                                         "SD of the per-pixel E_a (fit noise included)"),
        "activation_fit_noise_ev": noise,
        # (ln2 k T^2 / E_a falls as E_a rises: the median's relative SE is the median E_a's)
        "median_doubling_c": Estimate(float(np.median(td)), float(np.median(td)) * math.hypot(
                                          1.2533 * spread / math.sqrt(n), common_se_ev) / med
                                      if n > 1 and med > 0 else math.nan, "C",
                                      f"median of ln2 k T^2 / E_a at {at_c:g} C") if td.size else Estimate.na("no E_a", "C"),
        "regimes": regimes(fit),
        "hot_by_activation": int(hot_by_activation(fit).sum()),
        **meyer_neldel(fit),
    }


def pixel_rates(exposure_s, mean_maps, var_maps, n_frames) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's dark rate at one temperature: the weighted slope of its mean against exposure
    (``mean_maps`` (n_exp, R, C)); each mean's SE is sqrt(variance / frames) with the pixel's
    temporal variance taken from a line of its ``var_maps`` against exposure (read noise plus
    dark shot noise: a stage's own variance of a few frames is too noisy a weight -- weighted
    fits with noisy weights understate their errors). (rate map, SE map) in the maps' unit per
    second."""
    t = np.asarray(exposure_s, np.float64)
    m = np.asarray(mean_maps, np.float64)
    shape = m.shape[1:]
    y = m.reshape(m.shape[0], -1)
    v = np.asarray(var_maps, np.float64).reshape(y.shape)
    n = np.broadcast_to(np.asarray(n_frames, np.float64), t.shape)[:, None]
    if t.size >= 3:
        neg, _s, icpt, *_ = _wls(t[:, None], v, np.ones_like(v), False)
        v = icpt[None, :] - neg[None, :] * t[:, None]
    s = np.sqrt(np.maximum(v, 1 / 12) / n)
    neg_slope, slope_se, *_ = _wls(t[:, None], y, 1.0 / s**2, True)
    return (-neg_slope).reshape(shape), slope_se.reshape(shape)
