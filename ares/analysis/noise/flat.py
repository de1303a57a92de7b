"""Gain part of the decomposition from a flat (illuminated) and a dark stack.

Model (DESIGN.md): ``v = dark + G * Cg[c] * Rg[r] * Pg[r,c] * (q + delta)``.

*Signal and conversion gain.* ``S = mean(flat) - mean(dark)`` (DN). Shot noise ``delta``
is independent from pixel to pixel and frame to frame, so it lands entirely in the
*pixel-temporal* term of the three-way ANOVA (``MS_E``), never in the row, column or
frame-global temporal terms -- which do hold light-source flicker and row noise that
the plain per-pixel temporal variance would mistake for shot noise. For a balanced
design ``E[MS_E]`` is exactly the pixel-averaged residual variance, so::

    G = (Pt_flat - Pt_dark) / S           [DN/e-]   (photon transfer, one level)

(quantization 1/12 DN^2 is in both Pt and cancels). With a gain given from elsewhere
(e.g. a PTC fit) the Poisson check ``(Pt_flat - Pt_dark) / (G * S)`` should be 1.
``q = S / G`` (mean e-), ``delta = (Pt_flat - Pt_dark) / G^2`` (shot-noise variance, e-^2).

*Gain non-uniformity.* ``D = mean_flat - mean_dark`` holds no offset FPN (it cancels);
its two-way (rows x columns) ANOVA gives row, column and pixel variances of ``D`` that
still include temporal noise averaged over the frames, removed without bias with the two
three-way tables (``Pt/F`` from the pixel term, ``Rt/F``, ``Ct/F`` from the row and
column terms). Divided by ``S^2`` they are the variances of the relative gains
``Cg, Rg, Pg`` (mean 1; products linearized, fine for percent-level non-uniformity).

Illumination is never flat (``illumination=``):

* ``"none"`` -- the exact ANOVA above;
* ``"surface"`` -- subtract from ``D`` a fitted 2-D polynomial (``surface_order``,
  default 2) and normalize by the mean squared surface instead of ``S^2``; the
  pure-row / pure-column / mixed terms of the fit use up ``k``, ``k`` and the mixed
  count of degrees of freedom, which the mean squares account for;
* ``"highpass"`` -- EMVA 1288 Release 4.0 non-uniformity high-pass: subtract from ``D``
  its smoothing by a 7x7 box, then an 11x11 box, then a 3x3 binomial filter
  (``D - B3*B11*B7*D``), and drop a 9-pixel border. The filter changes the variance of
  every component by a factor known from the kernel (``k1 = sum((delta - L1)^2)`` for row
  and column effects, ``k2 = sum(h^2)`` for white pixel effects), which is divided out;
  standard errors use the effective degrees of freedom of the filtered (correlated)
  field. This mode is approximate (it assumes effects white along the filtered axis).

Every result is an ``Estimate``; dark-only data give ``Estimate.na``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ares.analysis.noise.accumulate import StackAccumulator
from ares.analysis.noise.anova import AnovaTable, anova_table, realisation_var
from ares.analysis.spatial.pattern_se import part_variance
from ares.analysis.spatial.nonuniformity import kernel_1d, smooth, white_gains
from ares.analysis.stats.estimate import EXACT_GAIN, Estimate

__all__ = ["decompose_flat", "gain_na", "highpass_emva", "GAIN_NAMES", "two_way"]

GAIN_NAMES = ("G", "Cg", "Rg", "Pg", "q", "delta")
_DARK_ONLY = "dark stack: no gain components"


def gain_na(reason: str = _DARK_ONLY) -> dict[str, Estimate]:
    units = {"G": "DN/e-", "Cg": "1", "Rg": "1", "Pg": "1", "q": "e-", "delta": "e-^2"}
    return {k: Estimate.na(reason, units[k]) for k in GAIN_NAMES}


_L1 = kernel_1d("4.0")  # length 19, centre index 9
_RAD = len(_L1) // 2


def highpass_emva(img: np.ndarray) -> np.ndarray:
    """EMVA 1288 4.0 high-pass over the whole image: ``img - B3*B11*B7*img`` (reflecting
    borders; ``emva_spatial.smooth``)."""
    img = np.asarray(img, np.float64)
    return img - smooth(img, "4.0", border="reflect")


@functools.cache
def hp_factors():
    """Filter gains and squared-coefficient sums of the 4.0 high-pass (computed on first use)."""
    k1, k2 = white_gains("4.0")
    h1 = -_L1.copy()
    h1[_RAD] += 1.0
    h2 = -np.outer(_L1, _L1)
    h2[_RAD, _RAD] += 1.0
    a1 = np.correlate(h1, h1, "full") / k1
    a2 = _autocorrelation_2d(h2) / k2
    return k1, k2, float((a1 * a1).sum()), float((a2 * a2).sum())


def _autocorrelation_2d(h: np.ndarray) -> np.ndarray:
    """Full 2-D autocorrelation of a small kernel (19 x 19 here: 37 x 37 shifted products),
    in numpy: scipy.signal's import (0.4 s) cost more than the sum itself."""
    n0, n1 = h.shape
    p = np.zeros((3 * n0 - 2, 3 * n1 - 2))
    p[n0 - 1:2 * n0 - 1, n1 - 1:2 * n1 - 1] = h
    return np.array([[float((p[i:i + n0, j:j + n1] * h).sum()) for j in range(2 * n1 - 1)]
                     for i in range(2 * n0 - 1)])


def two_way(img: np.ndarray, ddof_rows: int = 0, ddof_cols: int = 0, ddof_res: int = 0):
    """Two-way (rows x columns) ANOVA of one image: (MS_R, MS_C, MS_RC, df_R, df_C, df_RC)."""
    R, C = img.shape
    m = img.mean()
    mr = img.mean(axis=1) - m
    mc = img.mean(axis=0) - m
    res = img - m - mr[:, None] - mc[None, :]
    dfr, dfc = R - 1 - ddof_rows, C - 1 - ddof_cols
    dfe = (R - 1) * (C - 1) - ddof_res
    ms_r = C * float(mr @ mr) / dfr if dfr > 0 else math.nan
    ms_c = R * float(mc @ mc) / dfc if dfc > 0 else math.nan
    ms_e = float((res * res).sum()) / dfe if dfe > 0 else math.nan
    return ms_r, ms_c, ms_e, dfr, dfc, dfe


def _v(ms, df):  # unbiased estimate of var(MS) for MS ~ E chi2(df)/df
    return 2.0 * ms * ms / (df + 2) if df > 0 else math.inf


def _vp(ms, noise, df):
    """var(MS) given the sensor's gain pattern, ``noise`` the share of E[MS] its means' noise
    makes (``anova.ms_variance``: the measurement error of this sensor's pattern)."""
    return part_variance(ms, max(noise, 0.0), df, df) if df > 0 else math.inf


def _fit_surface(d: np.ndarray, order: int, good: np.ndarray | None = None):
    """(fit, row, column, mixed term counts): the least-squares polynomial surface of total
    ``order`` in the row and column coordinates, fitted to the pixels ``good`` (all when
    None) and evaluated everywhere."""
    R, C = d.shape
    y = np.linspace(-1, 1, R) if R > 1 else np.zeros(1)
    x = np.linspace(-1, 1, C) if C > 1 else np.zeros(1)
    Y, X = np.meshgrid(y, x, indexing="ij")
    terms = [(i, j) for i in range(order + 1) for j in range(order + 1 - i)]
    A = np.stack([(Y**i * X**j).ravel() for i, j in terms], axis=1)
    if good is None:
        coef, *_ = np.linalg.lstsq(A, d.ravel(), rcond=None)
    else:
        g = good.ravel()
        coef, *_ = np.linalg.lstsq(A[g], d.ravel()[g], rcond=None)
    fit = (A @ coef).reshape(R, C)
    n_rows = sum(1 for i, j in terms if i > 0 and j == 0)
    n_cols = sum(1 for i, j in terms if j > 0 and i == 0)
    n_mixed = sum(1 for i, j in terms if i > 0 and j > 0)
    return fit, n_rows, n_cols, n_mixed


def decompose_flat(
    flat_acc: StackAccumulator,
    dark_acc: StackAccumulator,
    gain: float | None = None,
    illumination: str = "highpass",
    surface_order: int = 2,
    flat_table: AnovaTable | None = None,
    dark_table: AnovaTable | None = None,
) -> dict[str, Estimate]:
    """Gain components G, Cg, Rg, Pg, q, delta (+ signal, poisson_ratio) with SEs.

    ``gain`` (DN/e-) given from elsewhere switches G from estimated to given and adds
    the Poisson check ``poisson_ratio``. See the module docstring for the method.
    """
    if getattr(flat_acc, "masked", False) or getattr(dark_acc, "masked", False):  # defect-masked (masked.py)
        m = flat_acc if getattr(flat_acc, "masked", False) else dark_acc
        return m.decompose_flat(flat_acc, dark_acc, gain, illumination, surface_order, flat_table, dark_table)
    if illumination not in ("highpass", "surface", "none"):
        from ares.errors import InputError

        raise InputError(f"illumination must be 'highpass', 'surface' or 'none', not {illumination!r}")
    if flat_acc.shape != dark_acc.shape:
        from ares.errors import InputError

        raise InputError(f"flat frames {flat_acc.shape} and dark frames {dark_acc.shape} differ in shape")
    tf = flat_table or anova_table(flat_acc)
    td = dark_table or anova_table(dark_acc)
    R, C = flat_acc.shape
    Ff, Fd = tf.F, td.F
    out: dict[str, Estimate] = {}
    # ---- signal
    msf, msd = tf.ms, td.ms
    S = tf.mean - td.mean
    var_S = 0.0
    for t, ms in ((tf, msf), (td, msd)):
        if t.df["F"] > 0:
            var_S += ms["F"] / (t.F * R * C)
    se_S = math.sqrt(var_S) if (Ff > 1 and Fd > 1) else math.nan
    out["signal"] = Estimate(S, se_S, "DN")
    # ---- photon transfer at this level
    ok_t = tf.df["E"] > 0 and td.df["E"] > 0
    if ok_t:
        dpt = msf["E"] - msd["E"]
        var_dpt = _v(msf["E"], tf.df["E"]) + _v(msd["E"], td.df["E"])
    if not ok_t:
        na = "needs >= 2 frames, rows and columns in both stacks"
        out.update({k: Estimate.na(na, u) for k, u in (("G", "DN/e-"), ("q", "e-"), ("delta", "e-^2"))})
    else:
        out.update(shot_noise_estimates(S, var_S, dpt, var_dpt, gain))
    # ---- gain non-uniformity (not measurable on a saturated or dark level: a flat equal to its
    # dark -- the light never came on -- would divide by a zero signal)
    why = no_shot_noise(S, var_S, dpt, var_dpt) if ok_t else ""
    if why:
        out.update({k: Estimate.na(why, "1") for k in ("Cg", "Rg", "Pg")})
    else:
        out.update(_nonuniformity(flat_acc, dark_acc, tf, td, S, var_S, illumination, surface_order))
    order = ["G", "Cg", "Rg", "Pg", "q", "delta", "signal"] + (["poisson_ratio"] if "poisson_ratio" in out else [])
    return {k: out[k] for k in order}


def no_shot_noise(S: float, var_S: float, dpt: float, var_dpt: float) -> str:
    """Why a level has no usable shot noise ('' when it has): no signal above dark, or a
    pixel-temporal variance not significantly (3 SE) above the dark's -- a fully saturated
    stage (every pixel clipped), stuck pixels or no light. G, q, delta and the gain
    non-uniformity are then not available, never a negative gain or charge."""
    if not (math.isfinite(S) and math.isfinite(dpt)):
        return "non-finite signal or variance"
    if S <= 3 * math.sqrt(max(var_S, 0.0)) or S <= 0:
        return f"no signal above dark (S = {S:.3g} DN)"
    if dpt <= 3 * math.sqrt(max(var_dpt, 0.0)):
        return (f"no shot noise: temporal variance {dpt:.3g} DN^2 above dark is not significant "
                "(saturated, stuck or no light)")
    return ""


def shot_noise_estimates(S: float, var_S: float, dpt: float, var_dpt: float, gain=None) -> dict:
    """G, q, delta (and the Poisson check when the gain is given) at one light level from
    the dark-subtracted signal ``S`` and pixel-temporal variance ``dpt`` with their
    variances (shared by the balanced and the masked decomposition)."""
    out: dict[str, Estimate] = {}
    why = no_shot_noise(S, var_S, dpt, var_dpt)
    if why:
        out.update({k: Estimate.na(why, u) for k, u in (("G", "DN/e-"), ("q", "e-"), ("delta", "e-^2"))})
        if gain is not None:
            out["poisson_ratio"] = Estimate.na(why, "1")
        return out
    if gain is None:
        G = dpt / S
        out["G"] = Estimate(G, abs(G) * math.sqrt(var_dpt / dpt**2 + var_S / S**2), "DN/e-")
        q = S / G  # = S^2 / dpt
        se_q = abs(q) * math.sqrt(4 * var_S / S**2 + var_dpt / dpt**2)
        out["q"] = Estimate(q, se_q, "e-")
        out["delta"] = Estimate(dpt / G**2, se_q, "e-^2")
    else:
        G = float(gain)
        out["G"] = Estimate.declared(G, "DN/e-", EXACT_GAIN)
        out["q"] = Estimate(S / G, math.sqrt(var_S) / abs(G), "e-")
        out["delta"] = Estimate(dpt / (G * G), math.sqrt(var_dpt) / (G * G), "e-^2")
        ratio = dpt / (G * S)
        out["poisson_ratio"] = Estimate(ratio, abs(ratio) * math.sqrt(var_dpt / dpt**2 + var_S / S**2), "1")
    return out


def _temporal_parts(tf: AnovaTable, td: AnovaTable):
    """Temporal variance left in the mean difference map, per pixel / row / column.

    Returns [(coef, MS key, table)] lists whose sum estimates each part: pixel Pt/F,
    row Rt/F = (MS_FR - MS_E)/(C F), column Ct/F = (MS_FC - MS_E)/(R F).
    """
    pix, row, col = [], [], []
    for t in (tf, td):
        F, R, C = t.F, t.R, t.C
        pix.append((1.0 / F, "E", t))
        row += [(1.0 / (C * F), "FR", t), (-1.0 / (C * F), "E", t)]
        col += [(1.0 / (R * F), "FC", t), (-1.0 / (R * F), "E", t)]
    return pix, row, col


def _lin(terms, scale=1.0):
    val = sum(a * t.ms[k] for a, k, t in terms) * scale
    var = sum((a * scale) ** 2 * _v(t.ms[k], t.df[k]) for a, k, t in terms)
    return val, var


def _highpass_vars(v_r, v_c, p_tot, dfr, dfc, dfe, k1, Rv, Cv, tr, tc, tp, whole):
    """(Rg, var, Cg, var, var Pg) of the high-passed map's parts (the temporal parts' own
    errors not in), the patterns held: the filtered row means hold the row pattern, the
    temporal tr and the pixel part's share p_tot / Cv (its noise), the pixel part p_tot the
    pixel pattern and tp; dof the filtered field's effective ones (shared by the masked form).
    ``whole`` = (rows, cols, pixels) of the map before the filter: what the filter and its
    border leave out of each pattern (``realisation_var``) is an error against the whole."""
    rg, cg, pg = v_r / k1 - p_tot / Cv - tr, v_c / k1 - p_tot / Rv - tc, p_tot - tp
    R, C, N = whole
    var_rg = _vp(v_r / k1, max(tr, 0.0) + p_tot / Cv, dfr) + realisation_var(rg, dfr, R - 1)
    var_cg = _vp(v_c / k1, max(tc, 0.0) + p_tot / Rv, dfc) + realisation_var(cg, dfc, C - 1)
    var_pg = _vp(p_tot, tp, dfe) + realisation_var(pg, dfe, N - 1)
    return rg, var_rg, cg, var_cg, var_pg


def _nonuniformity(flat_acc, dark_acc, tf, td, S, var_S, mode, order):
    R, C = flat_acc.shape
    names = ("Cg", "Rg", "Pg")
    if tf.F < 2 or td.F < 2 or R < 2 or C < 2:
        return {k: Estimate.na("needs >= 2 frames, rows and columns in both stacks", "1") for k in names}
    d = flat_acc.mean_map() - dark_acc.mean_map()
    pix, row, col = _temporal_parts(tf, td)
    norm = S * S  # relative-gain variance = variance of D / norm
    if mode in ("none", "surface"):
        ddof = (0, 0, 0)
        if mode == "surface":
            if min(R, C) <= order + 2:
                return {k: Estimate.na(f"region too small for an order-{order} surface", "1") for k in names}
            fit, nr, nc, nm = _fit_surface(d, order)
            # additive removal keeps the temporal parts unscaled; the gain pattern
            # rides on the local signal, so normalize by the mean squared surface
            d = d - fit
            norm = float(np.mean(fit * fit))
            ddof = (nr, nc, nm)
        ms_r, ms_c, ms_e, dfr, dfc, dfe = two_way(d, *ddof)
        tp, vtp = _lin(pix)
        tr, vtr = _lin(row)
        tc, vtc = _lin(col)
        # the patterns held (anova.py): a row or column mean's noise is the temporal one and the
        # pixel pattern's share (ms_e); the pixel part's the temporal tp
        pg = ms_e - tp
        var_pg = _vp(ms_e, tp, dfe) + vtp + realisation_var(pg, dfe, R * C - 1)  # its row and column means
        rg = (ms_r - ms_e) / C - tr
        var_rg = (_vp(ms_r, ms_e + C * max(tr, 0.0), dfr) + _vp(ms_e, tp, dfe)) / C**2 + vtr
        cg = (ms_c - ms_e) / R - tc
        var_cg = (_vp(ms_c, ms_e + R * max(tc, 0.0), dfc) + _vp(ms_e, tp, dfe)) / R**2 + vtc
    else:  # highpass
        if min(R, C) <= 2 * _RAD + 2:
            return {k: Estimate.na(f"region too small for the EMVA high-pass (needs > {2 * _RAD + 2} rows and columns)", "1") for k in names}
        hp = highpass_emva(d)[_RAD:-_RAD, _RAD:-_RAD]
        low = d[_RAD:-_RAD, _RAD:-_RAD] - hp
        norm = float(np.mean(low * low))
        Rv, Cv = hp.shape
        k1, k2, s1, s2 = hp_factors()
        m = hp.mean()
        mr = hp.mean(axis=1) - m
        mc = hp.mean(axis=0) - m
        res = hp - m - mr[:, None] - mc[None, :]
        v_rc = float((res * res).mean())
        v_r = float((mr * mr).mean())
        v_c = float((mc * mc).mean())
        tp, vtp = _lin(pix)
        tr, vtr = _lin(row)
        tc, vtc = _lin(col)
        p_tot = v_rc / (k2 - k1 / Cv - k1 / Rv)
        dfe = Rv * Cv / s2
        pg = p_tot - tp
        dfr, dfc = Rv / s1, Cv / s1
        rg, var_rg, cg, var_cg, var_pg = _highpass_vars(v_r, v_c, p_tot, dfr, dfc, dfe, k1, Rv, Cv, tr, tc, tp, (R, C, R * C))
        var_rg, var_cg, var_pg = var_rg + vtr, var_cg + vtc, var_pg + vtp
    s2_ = norm
    if not s2_ > 0:  # (a flat-field surface or high-pass residue of zero: nothing to normalise by)
        return {k: Estimate.na("no signal above dark to normalise the gain non-uniformity by", "1") for k in names}
    out = {}
    for k, val, var in (("Cg", cg, var_cg), ("Rg", rg, var_rg), ("Pg", pg, var_pg)):
        rel = val / s2_
        se = math.sqrt(var / s2_**2 + (2 * rel) ** 2 * var_S / s2_)
        out[k] = Estimate(rel, se, "1")
    return out


