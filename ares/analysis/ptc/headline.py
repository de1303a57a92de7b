"""The headline system gain K of a photon-transfer curve, by physics and evidence (issue 48):
the Astier 2019 fit wherever its curvature term is significant (a line over a bent range is
biased), the weighted line where it is not, the unweighted line (EMVA 1288 4.0 Linear Eq. 50's
form) where the weighted fits fail their residual checks or no errors are known -- each K's SE
from the errors the decisions use, with Student's t where it is a residual scatter. Pure
numpy: no I/O.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.median import fast_median
from ares.analysis.ptc.fit import (RUNS_P, LineFit, choose_gain_model, line_fit, origin_fit, residual_se_widening,
                                   runs_p)
from ares.analysis.ptc.saturation import PtcLevel


HEADLINE_P_MIN = 1e-3  # the chi-square probability below which a fit fails its own residual check


def gain_estimates(fit: list[PtcLevel], fit_note: str, errors_source: str):
    """(chosen K, WLS line K, EMVA origin K, Astier K, GainModel). The weights and residual
    tests use each level's decision error (``turnoff.decision_errors``: the counts' errors,
    with the signal's error through the slope, unless the measured scatter disagrees)."""
    S = np.array([lv.signal for lv in fit])
    V = np.array([lv.variance for lv in fit])
    N = np.array([lv.dof for lv in fit])
    Vse = np.array([lv.variance_se for lv in fit])
    E = np.array([lv.decision_se for lv in fit])
    no_errors = errors_source == "none" or not np.all(np.isfinite(E))
    gm = choose_gain_model(S, V, N, v_se=np.maximum(np.abs(V), 1e-300) if no_errors else E)
    how = {"measured": "w = 1/(measured scatter)^2", "counts": "w = 1/se(V)^2 (counts, signal error included)"}.get(
        errors_source, "unweighted")

    def est(lf: LineFit, note: str, residual: bool = False) -> Estimate:
        """K from line ``lf``; ``residual``: its SE is the residual scatter (n - 2 dof), so it
        carries Student's t (``fit.residual_se_widening``): 3 SE then cover what they claim
        (generated corpus curve 701: 3 levels, 4.8 % low at a residual SE of 1.3 %, "ok")."""
        if not math.isfinite(lf.slope):
            return Estimate.na(f"too few usable levels to fit ({lf.n}; see the excluded levels for why each "
                               "was dropped)", "DN/e-")
        if not lf.slope > 3 * lf.slope_se:
            return Estimate.na(f"the variance does not rise with the signal (slope {lf.slope:.3g} ± "
                               f"{lf.slope_se:.2g} DN/e- over {lf.n} levels)", "DN/e-")
        se = lf.slope_se
        if residual:
            w = residual_se_widening(lf.n - 2)
            se *= w
            rel = 100 * lf.slope_se / lf.slope
            if not lf.slope > 3 * se:
                return Estimate.na(f"K {lf.slope:.4g} DN/e- from a line through only {lf.n} levels: its SE "
                                   f"({rel:.2g} %) is their residual scatter on {lf.n - 2} degree{'s' * (lf.n > 3)} of freedom, "
                                   f"itself a guess -- Student's t makes 3 SE {3 * w:.3g} of them (± "
                                   f"{3 * w * rel:.2g} %): not measured by these data", "DN/e-")
            note += (f"; SE = the residual scatter's ({rel:.2g} %) x {w:.3g}, Student's t for {lf.n - 2} degrees of "
                     "freedom (3 SE cover what 3 normal SEs do)")
        return Estimate(lf.slope, se, "DN/e-", note)

    k_wls = est(gm.line, f"WLS line of V vs S, {how}, {fit_note}", gm.line.chi2_red > 1)
    k_org = est(origin_fit(S, V, Vse), f"EMVA 1288 origin fit, {fit_note}")
    ast = gm.astier
    if ast is not None and math.isfinite(ast.gain_e_per_dn) and ast.gain_e_per_dn > 0:
        # its SE, scaled by the residuals where they exceed the errors (``astier_fit``), is their scatter on
        # n - 3 dof: Student's t, as the line's (issue 48: 8 levels at 2 frames, K 3.2 SE off, "ok")
        w = residual_se_widening(ast.n - 3) if ast.chi2_red > 1 else 1.0
        k_ast = Estimate(1 / ast.gain_e_per_dn, w * ast.gain_se / ast.gain_e_per_dn**2, "DN/e-",
                         f"Astier 2019 exponential, a00 = {ast.a00:.3g} 1/e-, {fit_note}" + (
                             f"; SE = the residual scatter's (chi2/dof {ast.chi2_red:.3g}) x {w:.3g}, Student's t for "
                             f"{ast.n - 3} degrees of freedom" if w > 1 else ""))
    else:
        k_ast = Estimate.na("Astier fit needs >= 5 levels", "DN/e-")
    chosen = k_ast if gm.chosen == "astier" and k_ast.available else k_wls
    reason = gm.reason
    if (chosen is k_ast and not 3 * k_ast.se < k_ast.value and not gm.f_p < 0.05 and k_wls.available
            and 3 * k_wls.se < k_wls.value):
        # by evidence: on few levels Astier's extra parameter (residual SE, t for n - 3 dof) can cost K its measurement
        chosen = k_wls
        reason = (f"line: the Astier fit's K {k_ast.text()} is not measured by these {gm.line.n} levels (3 SE exceed it) "
                  f"and its curvature is not significant (F-test p {gm.f_p:.2g}): the line, one parameter fewer, is the headline")
    # by physics and evidence (issue 48): where the curvature term is significant the Astier fit is the
    # headline (a line over a bent range is biased). Where it is not and the line fails its residual check
    # against errors that describe the scatter, or no errors are known, the unweighted line with offset
    # (EMVA 1288 4.0 Linear Eq. 50), its SE the scatter's -- unless its residuals' signs say it does not
    # follow the levels (``fit.runs_p``: a plateau among them, corpus seed 3 curve 1140, K 59 % low "ok")
    line_fails = gm.line_p < HEADLINE_P_MIN
    if no_errors or (line_fails and chosen is not k_ast):
        lf = line_fit(S, V)
        k_ols = (est(lf, f"unweighted line of V vs S (SE from the residual scatter), {fit_note}", True)
                 if math.isfinite(lf.slope) and lf.slope > 3 * lf.slope_se else k_wls)
        runs = runs_p((V - (lf.slope * S + lf.intercept))[np.argsort(S)]) if k_ols.available else 1.0
        chosen = k_ols if not runs < RUNS_P else Estimate.na(  # (a rule that needs no errors: issue 48)
            f"the unweighted line's K {k_ols.text()} does not follow the levels fitted: its residuals run in long "
            f"stretches of one sign (Wald-Wolfowitz runs test p {runs:.1g}): a turnover or plateau no departure "
            "showed, or a bend no model here fits, lies among them", "DN/e-")
        reason = ("unweighted line: no variance errors are known and the levels are too few to measure their "
                  "scatter (the form of EMVA 1288 4.0 Eq. 50)" if no_errors else
                  f"unweighted line: the weighted line fails its own residual check (chi2/dof {gm.line.chi2_red:.3g}, "
                  f"p {gm.line_p:.2g}) and " + ("the Astier curvature term does not explain the residuals" if gm.astier
                                               is not None else gm.reason.removeprefix("linear: "))
                  + ", so the slope is not weighted (the form of EMVA 1288 4.0 Eq. 50)")
    elif chosen is k_ast and not gm.astier_p >= HEADLINE_P_MIN:
        reason += f"; its own residuals exceed the errors (chi2/dof {ast.chi2_red:.3g}): SE scaled by them"
    if chosen.available:
        chosen = Estimate(chosen.value, chosen.se, chosen.unit, f"{reason}; {chosen.note}")
    return chosen, k_wls, k_org, k_ast, gm


OUTLIER_SE = 5.0  # a fitted level this many SE of the measured scatter off its neighbours' curve is an outlier row
OUTLIER_MAX_FRACTION = 0.1  # ... at most this share of the fitted levels (more is not a few wild rows: a shape)
OUTLIER_MIN_LEVELS = 8  # ... and only where at least this many levels are fitted


def drop_outliers(fit: list[PtcLevel]) -> tuple[list[PtcLevel], list[PtcLevel]]:
    """(kept, dropped) of the levels the gain fits would use: a level whose variance lies more
    than ``OUTLIER_SE`` of its error -- the decision error, scaled up by the levels' measured
    scatter where that is larger (MAD about the local quadratic) -- off the quadratic
    through its 4 neighbours is a wild row (a cosmic ray in a flat pair, a flicker: the
    per-level scatter of real benches has heavy tails), dropped one at a time (of the
    levels farthest out, the one whose removal leaves the rest nearest their curves), each
    with its reason. A Gaussian level is that far out with probability 6e-7; under Student's
    t with 3 dof, ~1 level in 100 (issue 48; the rule is LSST cp_pipe's ``sigmaCutPtcOutliers``,
    default 5, on local residuals rather than a global model's so that a curve's bend is no
    outlier). Without decision errors nothing is dropped."""
    from ares.analysis.stats.scatter import MAD_TO_SIGMA, local_z

    kept = sorted(fit, key=lambda lv: lv.signal)
    dropped: list[PtcLevel] = []
    while len(kept) >= OUTLIER_MIN_LEVELS:
        S = np.array([lv.signal for lv in kept])
        V = np.array([lv.variance for lv in kept])
        E = np.array([lv.decision_se for lv in kept])
        if not (np.all(np.isfinite(E)) and np.all(E > 0)):
            break
        z = local_z(S, V, E)
        if not np.max(np.abs(z)) > OUTLIER_SE:
            break
        # a wild row drags its neighbours' local curves too: of the five levels farthest out, the
        # one whose removal leaves the others closest to their curves; the measured scatter (MAD)
        # taken without it, which on a sparse curve its neighbours' dragged residuals would inflate
        rest = {}
        for c in np.argsort(-np.abs(z))[:5]:
            m = np.arange(S.size) != c
            rest[int(c)] = local_z(S[m], V[m], E[m])
        j = min(rest, key=lambda c: float(np.max(np.abs(rest[c]))))
        zj = rest[j]
        if not abs(z[j]) > OUTLIER_SE * max(MAD_TO_SIGMA * float(fast_median(np.abs(zj - fast_median(zj)))), 1.0):
            break
        if len(dropped) + 1 > OUTLIER_MAX_FRACTION * len(fit):  # not a few wild rows: a shape (a plateau among
            return fit, []  # the fitted levels, a bend): left to the fits' own residual checks
        lv = kept.pop(j)
        dropped.append(dataclasses.replace(lv, status="excluded", reason=(
            f"outlier row: its variance {lv.variance:.4g} DN^2 lies {abs(z[j]):.3g} SE off the curve through its "
            f"neighbours (> {OUTLIER_SE:g} SE of the measured scatter, LSST cp_pipe's sigmaCutPtcOutliers rule): "
            "not fitted")))
    return kept, dropped
