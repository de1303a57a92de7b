"""Henderson's method I for ``masked.py``: the unbalanced ANOVA of a masked stack (the
three-way table of frames x rows x columns on the good cells, ``masked_table``) and of
one image (``henderson_two_way``). The derivation is in ``masked.py``'s docstring.

Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ares.analysis.spatial.pattern_se import part_variance
from ares.errors import InputError

_THETA = ("frame_global", "Rt", "Ct", "Pt", "Rs", "Cs", "Ps")
_MS_KEYS = ("F", "FR", "FC", "E", "R", "C", "RC")


def _layout(good: np.ndarray):
    nr, nc = good.sum(axis=1), good.sum(axis=0)
    N = int(nr.sum())
    Rp, Cp = int((nr > 0).sum()), int((nc > 0).sum())
    kr = float((nr.astype(float) ** 2).sum() / N) if N else math.nan
    kc = float((nc.astype(float) ** 2).sum() / N) if N else math.nan
    return nr, nc, N, Rp, Cp, kr, kc


def _spatial_forms(img: np.ndarray, good: np.ndarray):
    """(SS_R, SS_C, SS_RC) of one image on the good cells (Henderson I, centred)."""
    nr, nc = good.sum(axis=1), good.sum(axis=0)
    N = int(nr.sum())
    z = np.where(good, img, 0.0)
    z = np.where(good, z - z.sum() / N, 0.0)
    yr, yc = z.sum(axis=1), z.sum(axis=0)
    t0 = float((z * z).sum())
    tr = float((yr[nr > 0] ** 2 / nr[nr > 0]).sum())
    tc = float((yc[nc > 0] ** 2 / nc[nc > 0]).sum())
    tm = 0.0  # centred
    return tr - tm, tc - tm, t0 - tr - tc + tm


def _k_two_way(N, Rp, Cp, kr, kc):
    """E[SS_R, SS_C, SS_RC] = K @ (row var, col var, residual var) for one replicate."""
    return np.array([
        [N - kr, Rp - kc, Rp - 1],
        [Cp - kr, N - kc, Cp - 1],
        [kr - Cp, kc - Rp, N - Rp - Cp + 1],
    ], np.float64)


def henderson_two_way(img: np.ndarray, good: np.ndarray, ddof=(0, 0, 0), noise=None) -> dict:
    """Unbiased row / column / residual variances of one image on the good cells.

    Returns {"row", "col", "res": (value, variance)} (Henderson method I, variances of the
    estimates by Satterthwaite). ``ddof`` = degrees of freedom used up by a fitted
    surface in the row, column and residual terms (approximate, as ``flat.two_way``).
    ``noise`` = the image's temporal (row, column, pixel) variances: the variances are then
    the image's pattern held (``anova.ms_variance``): a row or column mean square's noise its
    temporal share and the residual's (pattern included), the residual's its temporal one.
    """
    nr, nc, N, Rp, Cp, kr, kc = _layout(good)
    ss = np.array(_spatial_forms(img, good))
    K = _k_two_way(N, Rp, Cp, kr, kc)
    # a fitted surface removes ddof of each term's df, and that share of its expectation
    full = K[:, 2].copy()
    df = full - np.asarray(ddof, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        K *= (df / full)[:, None]
    if np.any(df <= 0):
        return {k: (math.nan, math.inf) for k in ("row", "col", "res")}
    ms = ss / df
    Km = K / df[:, None]
    Ki = np.linalg.inv(Km)
    th = Ki @ ms
    vms = 2 * ms * ms / (df + 2)
    if noise is not None:
        tr, tc, tp = (max(float(x), 0.0) for x in noise)
        res = max(float(th[2]), tp)  # the residual's variance, pixel pattern and temporal
        for i, n in enumerate((Km[0] @ (tr, tc, res), Km[1] @ (tr, tc, res), Km[2] @ (tr, tc, tp))):
            vms[i] = part_variance(ms[i], float(n), df[i], df[i])
    var = (Ki * Ki) @ vms
    return {k: (float(th[i]), float(var[i])) for i, k in enumerate(("row", "col", "res"))}


# ---------------------------------------------------------------------- three-way table
@dataclass(frozen=True)
class MaskedTable:
    """Unbalanced ANOVA of a masked stack: sums of squares, df, EMS matrix, estimates."""

    F: int
    R: int  # rows / columns holding good cells
    C: int
    N: int  # good pixels
    mean: float
    ss: dict
    df: dict
    K: np.ndarray = field(repr=False)  # E[MS] = K @ theta (order _THETA)
    kr: float = 0.0
    kc: float = 0.0
    sum_nr2: float = 0.0
    sum_nc2: float = 0.0

    @property
    def ms(self) -> dict:
        return {k: (self.ss[k] / self.df[k] if self.df[k] > 0 else math.nan) for k in _MS_KEYS}

    @property
    def ok(self) -> bool:
        return all(self.df[k] > 0 for k in _MS_KEYS)

    def estimates(self) -> tuple[np.ndarray, np.ndarray]:
        """theta (order fg, Rt, Ct, Pt, Rs, Cs, Ps) and its coefficient matrix on MS."""
        Ki = np.linalg.inv(self.K)
        ms = np.array([self.ms[k] for k in _MS_KEYS])
        return Ki @ ms, Ki

    def ms_variances(self) -> np.ndarray:
        """var(MS_k) in ``_MS_KEYS`` order, as ``anova.ms_variance``: a temporal mean square's
        chi-square (Satterthwaite); a spatial one's given the sensor's pattern
        (``pattern_se.part_variance``), its noise E[MS_k] with the patterns held fixed set to 0
        (R, C: Rs and Cs -- the pixel pattern's share in the means is noise to them; RC: Ps too)."""
        th, _ = self.estimates()
        th = np.maximum(th, 0.0)
        ms = np.array([self.ms[k] for k in _MS_KEYS])
        df = np.array([self.df[k] for k in _MS_KEYS], float)
        out = 2 * ms * ms / (df + 2)
        for k, fixed in (("R", ("Rs", "Cs")), ("C", ("Rs", "Cs")), ("RC", ("Rs", "Cs", "Ps"))):
            i = _MS_KEYS.index(k)
            t = th.copy()
            t[[_THETA.index(f) for f in fixed]] = 0.0
            out[i] = part_variance(ms[i], float(self.K[i] @ t), df[i], df[i])
        return out

    def combo(self, coef_theta) -> tuple[float, float]:
        """Value and variance of sum coef*theta (``ms_variances``)."""
        th, Ki = self.estimates()
        a = np.asarray(coef_theta, float) @ Ki  # coefficients on the MS
        ms = np.array([self.ms[k] for k in _MS_KEYS])
        return float(a @ ms), float(((a * a) * self.ms_variances()).sum())


def masked_table(acc) -> MaskedTable:
    """The unbalanced three-way table of a ``MaskedStackAccumulator``."""
    F = acc.n_frames
    nr, nc, N, Rp, Cp, kr, kc = _layout(acc.good)
    if N == 0:
        raise InputError("every pixel is masked")
    t = acc.temporal_forms()
    T0, TR, TC, Tm = t["T0"], t["TR"], t["TC"], t["Tm"]
    ss_r, ss_c, ss_rc = _spatial_forms(acc.mean_map(), acc.good)
    ss = {"F": Tm, "FR": TR - Tm, "FC": TC - Tm, "E": T0 - TR - TC + Tm,
          "R": F * ss_r, "C": F * ss_c, "RC": F * ss_rc}
    f1 = F - 1
    # rows: E[SS]/(F-1) for the temporal forms, in theta order (fg, Rt, Ct, Pt)
    kt = np.array([
        [N, kr, kc, 1],
        [0, N - kr, Rp - kc, Rp - 1],
        [0, Cp - kr, N - kc, Cp - 1],
        [0, kr - Cp, kc - Rp, N - Rp - Cp + 1],
    ], np.float64)
    ks = _k_two_way(N, Rp, Cp, kr, kc)  # on (Rs + Rt/F, Cs + Ct/F, Ps + Pt/F)
    K = np.zeros((7, 7))
    K[:4, :4] = f1 * kt
    # F * ks @ (Rs, Cs, Ps) + ks @ (Rt, Ct, Pt)
    K[4:, 4:] = F * ks
    K[4:, 1:4] = ks
    df = {"F": f1, "FR": f1 * (Rp - 1), "FC": f1 * (Cp - 1), "E": f1 * (N - Rp - Cp + 1),
          "R": Rp - 1, "C": Cp - 1, "RC": N - Rp - Cp + 1}
    dfv = np.array([df[k] for k in _MS_KEYS], float)
    with np.errstate(divide="ignore", invalid="ignore"):
        Kms = K / np.where(dfv > 0, dfv, np.nan)[:, None]
    return MaskedTable(F, Rp, Cp, N, acc.mean(), ss, df, Kms, kr, kc,
                       float((nr.astype(float) ** 2).sum()), float((nc.astype(float) ** 2).sum()))
