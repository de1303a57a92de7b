"""EMVA 1288 4.0 Linear Eq. 50's K as the conversion gain of the figures in electrons.

Eq. 50 defines K as the slope of a straight line of temporal variance against signal over
0 - 70 % of saturation. Every figure the Linear sheet gives in electrons or photons is a DN
figure divided by it (sigma_d, Eq. 53; mu_e.min, Eq. 26; eta = R / K, Eq. 52, and what
follows from eta: mu_p.min, mu_e.sat, SNR_max, DR; DSNU1288 and its parts, Eq. 66): what
those figures need is the gain at which the DN were made, i.e. the photon-transfer slope
at zero signal. Where the curve bends (brighter-fatter flattening, an ADC's INL bow) the
line's slope over 0 - 70 % is not that slope, by more than its own SE: on the simulated
sensor Eq. 50's K is +3 of its SEs above the true gain at 8 frames (benchmarks/truth_z.md),
on the EMVA reference CCD 5 % below the zero-signal gain of the same levels.

The data cannot show the curve is a line at Eq. 50's precision: the zero-signal slope they
determine (the Astier 2019 fit of the same levels, ``ptc.fit.astier_fit``, SE widened by
Student's t as the photon-transfer headline's) has an SE ~1.7x the line's, and a bend hidden
within it still biases the line by several of the line's SEs (benchmarks/truth_z.md: the
discrepancy carried only where resolved leaves 2 of 8 DSNU1288 e- wrong "ok" at 8 frames,
1 of 7 at 4, where it is never resolved; simulator seed 1 at 8 frames: D 0.45 SE, Eq. 50's K
+3.3 SE). So the figures in
electrons carry, for K, the uncertainty of K as the zero-signal gain: the discrepancy
D = K_eq50 - K_0 (known from the data) and K_0's own SE, ``hypot(D, se_0)`` (never less than
Eq. 50's SE). Their values stay as written (the text's K); K itself keeps the line's SE --
it is the text's slope over 0 - 70 %, and the "K statement" compares it with the headline.
The dark current's SE is the regression's one sigma that Section 7.1 prescribes: its note
says how large the gain term would be against it, instead.

``gain_term`` measures it; ``attribute`` writes into each widened figure's note how much of
its SE the gain term is. Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.estimate import Estimate


@dataclass(frozen=True)
class GainTerm:
    k0: Estimate  # the zero-signal K of the same levels (Astier 2019), or not available with the reason
    diff: float  # K_eq50 - K_0 (DN/e-), NaN without K_0
    diff_se: float  # both fits' SEs combined (their correlation through the shared levels ignored)
    se: float  # the SE of Eq. 50's K as the zero-signal gain: max(K's, hypot(diff, K_0's SE)); K's without K_0
    k_se: float  # Eq. 50's own SE (the regression's)
    sentence: str
    name: str = "Eq. 50's K"  # the K the figures are divided by (Release 3.x: the origin fit's)

    @property
    def widens(self) -> bool:
        return self.se > self.k_se

    def share(self) -> float:
        """The gain term's part of K's widened variance, 0 - 1."""
        return 1.0 - (self.k_se / self.se) ** 2 if self.se > 0 else 0.0


def gain_term(mu, var, var_se, dof, K: Estimate, name: str = "Eq. 50's K") -> GainTerm:
    """The zero-signal K of the levels Eq. 50 fitted (``mu``, ``var``: dark-subtracted signal
    and temporal variance, ``var_se`` their variance SEs) and Eq. 50's K's (``name``) uncertainty as
    that gain (module docstring)."""
    from ares.analysis.ptc.fit import astier_fit, residual_se_widening

    mu, var = np.asarray(mu, float), np.asarray(var, float)
    af = astier_fit(mu, var, np.asarray(dof, float), v_se=np.asarray(var_se, float))
    g = af.gain_e_per_dn
    if not (math.isfinite(g) and g > 0 and math.isfinite(af.gain_se)):
        why = (f"the zero-signal gain is not determined by these {mu.size} levels (the Astier 2019 fit needs >= 4 "
               "and did not converge)")
        return GainTerm(Estimate.na(why, "DN/e-"), math.nan, math.nan, K.se, K.se, why + ": no gain term", name)
    w = residual_se_widening(af.n - 3) if af.chi2_red > 1 else 1.0
    k0 = Estimate(1 / g, w * af.gain_se / g ** 2, "DN/e-", f"Astier 2019 fit of the same {af.n} levels, a00 = "
                                                          f"{af.a00:.3g} ± {af.a00_se:.2g} 1/e-")
    if not k0.value > 3 * k0.se:  # (as the headline: a zero-signal K 3 SE do not bound is not measured)
        why = f"the zero-signal gain of these {af.n} levels, {k0.text()}, is not measured (3 SE exceed it)"
        return GainTerm(Estimate.na(why, "DN/e-"), math.nan, math.nan, K.se, K.se, why + ": no gain term", name)
    diff = K.value - k0.value
    diff_se = math.hypot(K.se, k0.se)
    se = max(K.se, math.hypot(diff, k0.se))
    sentence = (f"{name} {K.text()} as the gain at zero signal: the same levels' zero-signal K is {k0.text()} "
                f"(Astier 2019), a difference of {Estimate(diff, diff_se, 'DN/e-').text()} "
                f"({abs(diff) / diff_se:.2g} SE); the figures in electrons and photons carry K's uncertainty as that "
                f"gain, hypot(difference, its SE) = {se:.2g} DN/e- ({se / K.se:.2g}x its own SE)")
    return GainTerm(k0, diff, diff_se, se, K.se, sentence, name)


def attribute(widened: dict[str, Estimate], plain: dict[str, Estimate], term: GainTerm) -> dict[str, Estimate]:
    """``widened`` with each figure whose SE the gain term raised (against ``plain``, the same
    figures with Eq. 50's own SE) saying how much of its SE that is."""
    out = dict(widened)
    if not term.widens:
        return out
    for k, e in widened.items():
        p = plain.get(k)
        if not (isinstance(e, Estimate) and isinstance(p, Estimate) and e.available and p.available
                and math.isfinite(e.se) and math.isfinite(p.se) and e.se > p.se > 0 and not e.bound):
            continue
        share = 1.0 - (p.se / e.se) ** 2
        note = (f"{e.note}; SE {e.se:.2g} {e.unit}".rstrip() + f", {100 * share:.0f} % of its variance the gain "
                f"term (without it {p.se:.2g}): K as the zero-signal gain, hypot({term.name} - zero-signal K "
                f"{term.diff:+.2g}, its SE {term.k0.se:.2g}) DN/e- (ares.analysis.emva.gain_term)")
        out[k] = Estimate(e.value, e.se, e.unit, note, e.bound, e.exact)
    return out
