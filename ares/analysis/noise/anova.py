"""Dark noise decomposition: balanced three-way crossed random-effects ANOVA.

The dark part of the ARTEMIS model (DESIGN.md, seed 001) for frame f, row r, column c::

    v[f,r,c] = o + g[f] + Rs[r] + Cs[c] + Rt[f,r] + Ct[f,c] + Ps[r,c] + Pt[f,r,c]

is a balanced three-way crossed random-effects design (frames x rows x columns) with
``g`` the frame-global temporal offset (flicker, clamp drift). With the sums of squares
of SCIENCE.md ("Three-way ANOVA") and ``MS = SS/df`` the expected mean squares are::

    E[MS_E]  = Pt                      E[MS_F] = Pt + C Rt + R Ct + R C fg
    E[MS_FR] = Pt + C Rt               E[MS_R] = Pt + C Rt + F Ps + F C Rs
    E[MS_FC] = Pt + R Ct               E[MS_C] = Pt + R Ct + F Ps + F R Cs
    E[MS_RC] = Pt + F Ps

so each variance is an unbiased linear combination of mean squares (Pt = MS_E,
Rt = (MS_FR - MS_E)/C, ..., fg = (MS_F - MS_FR - MS_FC + MS_E)/(R C)). Negative values
are reported as they come (clipping would bias them); ``sigma_view`` gives clipped
square roots for display.

Standard errors: the mean squares are independent, var(sum a_k MS_k) = sum a_k^2
var(MS_k). A temporal one (F, FR, FC, E) under normality is E[MS_k] chi2(df_k)/df_k:
var 2 E[MS_k]^2/df_k, E[MS_k]^2 estimated without bias by MS_k^2 df_k/(df_k + 2)
(Satterthwaite). A spatial one (R, C, RC) is taken given THIS sensor's pattern -- the
figures are a measurement of this sensor, as the EMVA non-uniformity's
(``spatial.pattern_se``), not the spread another sensor of the same pattern statistics
would show (sqrt(2 / df) times the mean square: up to 16x larger on the main job; truth_z.md):
MS_k / df_k-scaled is a non-central chi-square in the noise its means hold
(``pattern_se.part_variance``: var (4 n p + 2 n^2) / df_k, n the noise's share of E[MS_k],
p = MS_k - n the pattern's). The row and column means' noise is the temporal one and the
pixel pattern's share (R: Pt + C Rt + F Ps, C: Pt + R Ct + F Ps): a pixel pattern's row
means are a row pattern no design tells apart, removed as their expectation F Ps, so
their realisation is an error of Rs and Cs against the sensor's row and column patterns;
RC's is Pt (the pixel pattern held fixed).

Every sum of squares is an exact function of the accumulator's per-pixel sums and sums
of squares, per-(frame,row) and per-(frame,column) sums (one pass, any frame count).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.noise.accumulate import StackAccumulator
from ares.analysis.spatial.pattern_se import part_variance
from ares.analysis.stats.estimate import Estimate

__all__ = ["AnovaTable", "anova_table", "decompose_dark", "sigma_view", "in_electrons", "DARK_NAMES",
           "ms_variance", "realisation_var", "with_realisation"]

DARK_NAMES = ("o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global")
_EFFECTS = ("F", "R", "C", "FR", "FC", "RC", "E")


@dataclass(frozen=True)
class AnovaTable:
    """Sums of squares, degrees of freedom and mean squares of the F x R x C design."""

    F: int
    R: int
    C: int
    mean: float
    ss: dict
    df: dict

    @property
    def ms(self) -> dict:
        return {k: (self.ss[k] / self.df[k] if self.df[k] > 0 else math.nan) for k in _EFFECTS}


def anova_table(acc: StackAccumulator) -> AnovaTable:
    """Three-way ANOVA table from an accumulator (no frame data needed); kept by the
    accumulator until it changes (a stage's analysis asks for it several times, and a
    reused matched dark at every stage)."""
    if getattr(acc, "masked", False):  # defect-masked stack: unbalanced ANOVA (masked.py, via the accumulator)
        return acc.anova_table()
    cached = getattr(acc, "_cached", None)
    return cached("anova", lambda: _table(acc)) if cached is not None else _table(acc)


def _table(acc) -> AnovaTable:
    F = acc.n_frames
    R, C = acc.shape
    mrc = acc.mean_map()
    m = float(mrc.mean())
    d_rc = mrc - m
    mr = d_rc.mean(axis=1)
    mc = d_rc.mean(axis=0)
    ts = acc.temporal_sums()  # exact frame, frame x row, frame x column SS
    ss = {
        "F": float(ts["ss_f"]),
        "R": F * C * float(np.sum(mr**2)),
        "C": F * R * float(np.sum(mc**2)),
        "FR": float(ts["ss_fr"]),
        "FC": float(ts["ss_fc"]),
        "RC": F * float(np.sum((d_rc - mr[:, None] - mc[None, :]) ** 2)),
    }
    # sum_frc (x - m_rc)^2 = SS_F + SS_FR + SS_FC + SS_E
    ss["E"] = ts["w"] - ss["F"] - ss["FR"] - ss["FC"]
    for k in ss:  # exact data give >= 0; clamp rounding residue only
        if ss[k] < 0:
            ss[k] = 0.0
    df = {
        "F": F - 1,
        "R": R - 1,
        "C": C - 1,
        "FR": (F - 1) * (R - 1),
        "FC": (F - 1) * (C - 1),
        "RC": (R - 1) * (C - 1),
        "E": (F - 1) * (R - 1) * (C - 1),
    }
    return AnovaTable(F, R, C, m, ss, df)


# the temporal mean squares beside MS_E whose excess is noise in a spatial mean square's means
_NOISE_OF = {"R": ("FR", "RC"), "C": ("FC", "RC"), "RC": ()}


def ms_variance(tab: AnovaTable, k: str) -> float:
    """var(MS_k): a temporal mean square's chi-square (Satterthwaite); a spatial one's given the
    sensor's pattern, in the noise of its means (module docstring)."""
    ms, df = tab.ms[k], tab.df[k]
    if k not in _NOISE_OF:
        return 2.0 * ms**2 / (df + 2)
    e = tab.ms["E"]
    noise = e + sum(max(tab.ms[j] - e, 0.0) for j in _NOISE_OF[k])
    return part_variance(ms, noise, df, df)


def realisation_var(v: float, dof_est: float, dof_truth: float) -> float:
    """The error a pattern variance's estimator makes against the sensor's whole pattern when it
    sees only part of it: the pixel pattern's row and column means (the design gives them to Rs
    and Cs, their expectation removed), a high-pass's low frequencies and dropped border. For a
    white pattern the whole pattern's sample variance (dof_truth) is sufficient, so an unbiased
    quadratic estimator of dof_est effective dof is off from it by var 2 v^2 (1 / dof_est -
    1 / dof_truth) -- for Ps 2 (R + C - 2) Ps^2 / (R C)^2, as large as the temporal error where
    the pixel pattern outweighs the noise. v below 0: 0."""
    return 2.0 * max(v, 0.0) ** 2 * max(1.0 / dof_est - 1.0 / dof_truth, 0.0) if dof_est > 0 else math.inf


def with_realisation(e: Estimate, dof_est: float, dof_truth: float) -> Estimate:
    """``e`` with ``realisation_var`` in its SE."""
    if not (e.available and math.isfinite(e.se)):
        return e
    return dataclasses.replace(e, se=math.sqrt(e.se**2 + realisation_var(e.value, dof_est, dof_truth)))


def _combo(tab: AnovaTable, coef: dict, scale: float, unit: str, need: str) -> Estimate:
    ms = tab.ms
    if any(tab.df[k] <= 0 for k in coef):
        return Estimate.na(need, unit)
    val = sum(a * ms[k] for k, a in coef.items()) / scale
    var = sum(a * a * ms_variance(tab, k) for k, a in coef.items()) / scale**2
    return Estimate(float(val), float(math.sqrt(var)), unit)


def _need(tab: AnovaTable, frames=False, rows=False, cols=False) -> str:
    parts = []
    if frames and tab.F < 2:
        parts.append(">= 2 frames")
    if rows and tab.R < 2:
        parts.append(">= 2 rows")
    if cols and tab.C < 2:
        parts.append(">= 2 columns")
    return "needs " + " and ".join(parts) if parts else ""


def decompose_dark(acc: StackAccumulator, table: AnovaTable | None = None) -> dict[str, Estimate]:
    """Unbiased dark components (DN; variances in DN^2) with standard errors.

    Keys: o (offset, DN), Cs, Ct, Rs, Rt, Ps, Pt, frame_global (variances, DN^2).
    A component the design cannot separate is ``Estimate.na("needs >= 2 frames")``.
    A ``MaskedStackAccumulator`` (defect mask) is decomposed by ``masked.py``.
    """
    if getattr(acc, "masked", False):
        return acc.decompose_dark(table)
    tab = table if table is not None else anova_table(acc)
    F, R, C = tab.F, tab.R, tab.C
    u = "DN^2"
    out: dict[str, Estimate] = {}
    # offset: var(grand mean) = (MS_F+MS_R+MS_C-MS_FR-MS_FC-MS_RC+MS_E)/(FRC), all present
    ms = tab.ms
    v = 0.0
    for k, a in (("F", 1), ("R", 1), ("C", 1), ("FR", -1), ("FC", -1), ("RC", -1), ("E", 1)):
        if tab.df[k] > 0:
            v += a * ms[k]
    # (the combination estimates F R C var(mean) >= sigma_Pt^2, whose own estimate is MS_E: noise can take
    # the combination below it, to 0 or less -- an SE of exactly 0 shown "exact" on a measured mean;
    # in 29 % of 2 x 4 x 4 white stacks. It is held at MS_E, the pixel temporal noise's share alone)
    if tab.df["E"] > 0:
        v = max(v, ms["E"])
    # with one frame the temporal mean squares are absent and the sum above has no meaning
    out["o"] = (Estimate(tab.mean, math.sqrt(max(v, 0.0) / (F * R * C)), "DN") if F >= 2 else
                Estimate(tab.mean, math.nan, "DN", "one frame: no standard error (needs >= 2 frames)"))
    specs = {
        "Pt": ({"E": 1}, 1, (True, True, True)),
        "Rt": ({"FR": 1, "E": -1}, C, (True, True, True)),
        "Ct": ({"FC": 1, "E": -1}, R, (True, True, True)),
        "Ps": ({"RC": 1, "E": -1}, F, (True, True, True)),
        "Rs": ({"R": 1, "FR": -1, "RC": -1, "E": 1}, F * C, (True, True, True)),
        "Cs": ({"C": 1, "FC": -1, "RC": -1, "E": 1}, F * R, (True, True, True)),
        "frame_global": ({"F": 1, "FR": -1, "FC": -1, "E": 1}, R * C, (True, True, True)),
    }
    for name, (coef, scale, needs) in specs.items():
        msg = _need(tab, *needs)
        out[name] = Estimate.na(msg, u) if msg else _combo(tab, coef, scale, u, msg)
    out["Ps"] = with_realisation(out["Ps"], (R - 1) * (C - 1), R * C - 1)  # its row and column means
    # With a single frame the spatial parts are still separable (two-way, temporal
    # included) but not unbiased for the fixed pattern alone: reported n/a above.
    return {k: out[k] for k in DARK_NAMES}


def sigma_view(components: dict[str, Estimate]) -> dict[str, Estimate]:
    """Square roots of the variance components (clipped at 0) in the unit's root.

    SE by the delta method, se(sigma) = se(var) / (2 sigma); a component whose variance
    estimate is <= 0 gets sigma 0 and se sqrt(se(var)) (an upper-limit scale).
    """
    out = {}
    for k, e in components.items():
        if not e.unit.endswith("^2"):
            continue
        unit = e.unit[:-2]
        if not e.available:
            out[k] = Estimate.na(e.note, unit)
        elif e.value <= 0:
            out[k] = Estimate(0.0, math.sqrt(e.se) if math.isfinite(e.se) else math.nan, unit, "clipped at 0")
        else:
            s = math.sqrt(e.value)
            out[k] = Estimate(s, e.se / (2 * s), unit)
    return out


def in_electrons(components: dict[str, Estimate], gain_dn_per_e: float) -> dict[str, Estimate]:
    """Convert DN / DN^2 estimates to e- / e-^2 with a conversion gain in DN/e-."""
    g = float(gain_dn_per_e)
    out = {}
    for k, e in components.items():
        if e.unit == "DN^2":
            f, unit = g * g, "e-^2"
        elif e.unit == "DN":
            f, unit = g, "e-"
        else:
            out[k] = e
            continue
        if not e.available:
            out[k] = Estimate.na(e.note, unit)
        elif e.bound:  # a limit stays a limit
            out[k] = Estimate.limit(e.value / f, e.bound, unit, e.note)
        else:
            out[k] = Estimate(e.value / f, e.se / f, unit, e.note)
    return out
