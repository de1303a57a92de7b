"""The noise decomposition of a defect-masked stack (``ares.analysis.noise.masked``'s accumulator dispatches here): the unbalanced three-way ANOVA of the dark (Henderson method I, ``masked_anova``) and the gain part of a flat with the spatial nonuniformity over the good pixels."""

from __future__ import annotations

import math
import numpy as np
from ares.errors import InputError
from ares.analysis.noise import flat as _flat
from ares.analysis.noise.anova import DARK_NAMES, realisation_var, with_realisation
from ares.analysis.stats.estimate import Estimate
from ares.analysis.spatial.nonuniformity import smooth
from ares.analysis.noise.masked_anova import _THETA, MaskedTable, henderson_two_way


# ---------------------------------------------------------------------- two-way forms
def decompose_dark_masked(acc, table: MaskedTable | None = None) -> dict[str, Estimate]:
    """Dark components (as ``anova.decompose_dark``) on the good pixels of a masked stack."""
    tab = table if isinstance(table, MaskedTable) else acc.anova_table()
    u = "DN^2"
    if tab.F < 2 or tab.R < 2 or tab.C < 2 or not tab.ok:
        msg = "needs >= 2 frames and >= 2 rows and columns of good pixels"
        out = {k: Estimate.na(msg, u) for k in DARK_NAMES}
        out["o"] = Estimate(tab.mean, math.nan, "DN")
        return out
    F, N = tab.F, tab.N
    out: dict[str, Estimate] = {}
    # var(good-pixel grand mean) = fg/F + sum n_r^2/N^2 (Rs + Rt/F) + sum n_c^2/N^2 (Cs + Ct/F) + (Ps + Pt/F)/N
    a, b = tab.sum_nr2 / N**2, tab.sum_nc2 / N**2
    cvec = [1 / F, a / F, b / F, 1 / (F * N), a, b, 1 / N]
    v, _ = tab.combo(cvec)
    for i, name in enumerate(_THETA):
        e = np.zeros(7)
        e[i] = 1
        val, var = tab.combo(e)
        out[name] = Estimate(val, math.sqrt(var), u)
    # (never below the pixel temporal noise's share Pt / (F N), as ``anova.decompose_dark``: an SE of 0 is "exact")
    out["o"] = Estimate(tab.mean, math.sqrt(max(v, out["Pt"].value / (F * N), 0.0)), "DN")
    out["Ps"] = with_realisation(out["Ps"], tab.df["RC"], N - 1)  # its row and column means
    return {k: out[k] for k in DARK_NAMES}


# ---------------------------------------------------------------------- flat
def _theta(tab: MaskedTable, name: str, scale: float = 1.0) -> tuple[float, float]:
    e = np.zeros(7)
    e[_THETA.index(name)] = scale
    return tab.combo(e)


def decompose_flat_masked(flat_acc, dark_acc, gain=None, illumination="highpass", surface_order=2,
                          flat_table=None, dark_table=None) -> dict[str, Estimate]:
    """``flat.decompose_flat`` on the good pixels of two masked stacks (same mask)."""
    if not (getattr(flat_acc, "masked", False) and getattr(dark_acc, "masked", False)):
        raise InputError("a masked flat decomposition needs masked flat and dark stacks (MaskedStackAccumulator)")
    if illumination not in ("highpass", "surface", "none"):
        raise InputError(f"illumination must be 'highpass', 'surface' or 'none', not {illumination!r}")
    if flat_acc.shape != dark_acc.shape or not np.array_equal(flat_acc.mask, dark_acc.mask):
        raise InputError("flat and dark stacks must have the same frame shape and mask")
    tf = flat_table if isinstance(flat_table, MaskedTable) else flat_acc.anova_table()
    td = dark_table if isinstance(dark_table, MaskedTable) else dark_acc.anova_table()
    out: dict[str, Estimate] = {}
    na = "needs >= 2 frames and >= 2 rows and columns of good pixels in both stacks"
    if not (tf.ok and td.ok and tf.F > 1 and td.F > 1):
        res = _flat.gain_na(na)
        res["signal"] = Estimate(tf.mean - td.mean, math.nan, "DN")
        return res
    S = tf.mean - td.mean
    var_S = tf.ms["F"] / (tf.F * tf.N) + td.ms["F"] / (td.F * td.N)
    se_S = math.sqrt(var_S)
    out["signal"] = Estimate(S, se_S, "DN")
    ptf, vptf = _theta(tf, "Pt")
    ptd, vptd = _theta(td, "Pt")
    dpt, var_dpt = ptf - ptd, vptf + vptd
    out.update(_flat.shot_noise_estimates(S, var_S, dpt, var_dpt, gain))
    out.update(_nonuniformity(flat_acc, dark_acc, tf, td, S, var_S, illumination, surface_order))
    order = ["G", "Cg", "Rg", "Pg", "q", "delta", "signal"] + (["poisson_ratio"] if "poisson_ratio" in out else [])
    return {k: out[k] for k in order}


def _temporal_in_mean(tf: MaskedTable, td: MaskedTable):
    """Temporal variance left in the mean difference map: pixel, row, column (value, var)."""
    res = []
    for name in ("Pt", "Rt", "Ct"):
        vals = vars_ = 0.0
        for t in (tf, td):
            e = np.zeros(7)
            e[_THETA.index(name)] = 1.0 / t.F
            v, w = t.combo(e)
            vals += v
            vars_ += w
        res.append((vals, vars_))
    return res


def _fill_lowpass(d: np.ndarray, good: np.ndarray) -> np.ndarray:
    """Masked pixels replaced by the EMVA low-pass of the good ones (normalized convolution:
    the low-pass of the image with its masked pixels zeroed over the low-pass of the good
    pixels' indicator). In place where it can: at 4096x3072 each temporary is 96 MB."""
    fill = smooth(np.where(good, d, 0.0), "4.0", border="reflect")
    low_w = smooth(good.astype(np.float64), "4.0", border="reflect")
    np.maximum(low_w, 1e-12, out=low_w)
    fill /= low_w
    del low_w
    np.copyto(fill, d, where=good)
    return fill


def _nonuniformity(flat_acc, dark_acc, tf, td, S, var_S, mode, order):
    names = ("Cg", "Rg", "Pg")
    R, C = flat_acc.shape
    good = flat_acc.good
    d = flat_acc.mean_map() - dark_acc.mean_map()
    (tp, vtp), (tr, vtr), (tc, vtc) = _temporal_in_mean(tf, td)
    norm = S * S
    if mode in ("none", "surface"):
        ddof = (0, 0, 0)
        if mode == "surface":
            if min(R, C) <= order + 2:
                return {k: Estimate.na(f"region too small for an order-{order} surface", "1") for k in names}
            fit, nr_, nc_, nm_ = _flat._fit_surface(d, order, good)
            d = d - fit
            norm = float(np.mean(fit[good] ** 2))
            ddof = (nr_, nc_, nm_)
        h = henderson_two_way(d, good, ddof, noise=(tr, tc, tp))  # the gain pattern held
        (rv, vr), (cv, vc), (pv, vp) = h["row"], h["col"], h["res"]
        n_good, rp, cp = int(good.sum()), int(good.any(axis=1).sum()), int(good.any(axis=0).sum())
        pg, var_pg = pv - tp, vp + vtp + realisation_var(pv - tp, n_good - rp - cp + 1 - ddof[2], n_good - 1)
        rg, var_rg = rv - tr, vr + vtr
        cg, var_cg = cv - tc, vc + vtc
    else:
        rad = _flat._RAD
        if min(R, C) <= 2 * rad + 2:
            msg = f"region too small for the EMVA high-pass (needs > {2 * rad + 2} rows and columns)"
            return {k: Estimate.na(msg, "1") for k in names}
        # (in place where the numbers stay the same: each temporary is a frame of float64)
        df_ = _fill_lowpass(d, good)
        del d
        hp = _flat.highpass_emva(df_)[rad:-rad, rad:-rad]
        low = np.subtract(df_[rad:-rad, rad:-rad], hp)
        del df_
        g = good[rad:-rad, rad:-rad]
        np.square(low, out=low)
        norm = float(np.mean(low[g]))
        del low
        Rv, Cv = hp.shape
        k1, k2, s1, s2 = _flat.hp_factors()
        nrow, ncol = g.sum(axis=1), g.sum(axis=0)
        hz = np.where(g, hp, 0.0)
        m = hz.sum() / g.sum()
        mr = np.where(nrow > 0, hz.sum(axis=1) / np.maximum(nrow, 1), m) - m
        mc = np.where(ncol > 0, hz.sum(axis=0) / np.maximum(ncol, 1), m) - m
        del hz
        res = hp - m
        del hp
        res -= mr[:, None]
        res -= mc[None, :]
        np.square(res, out=res)
        v_rc = float(res[g].mean())
        del res
        v_r = float((mr * mr).mean())
        v_c = float((mc * mc).mean())
        p_tot = v_rc / (k2 - k1 / Cv - k1 / Rv)
        dfe = g.sum() / s2
        pg = p_tot - tp
        rg, var_rg, cg, var_cg, var_pg = _flat._highpass_vars(v_r, v_c, p_tot, Rv / s1, Cv / s1, dfe, k1, Rv, Cv,
                                                              tr, tc, tp, (R, C, int(good.sum())))
        var_rg, var_cg, var_pg = var_rg + vtr, var_cg + vtc, var_pg + vtp
    out = {}
    for k, val, var in (("Cg", cg, var_cg), ("Rg", rg, var_rg), ("Pg", pg, var_pg)):
        rel = val / norm
        se = math.sqrt(var / norm**2 + (2 * rel) ** 2 * var_S / norm)
        out[k] = Estimate(rel, se, "1")
    return out
