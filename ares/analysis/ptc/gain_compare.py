"""Which system gain K is the headline, and how it stands against the EMVA 1288 4.0 value.

A scan that runs both the photon transfer (``ptc``) and the EMVA 1288 Release 4.0 Linear
evaluation (``emva4``) has two K from the same levels. EMVA 1288 4.0 Linear Section 6.6,
Eq. 50, defines K as the slope of an (unweighted) least-squares line with unknown offset of
sigma_y^2 - sigma_y.dark^2 versus mu_y - mu_y.dark over 0-70 % of saturation: that is THE K
of an EMVA datasheet. ARES's photon-transfer headline (issue 48) is the Astier 2019 fit
wherever >= 5 levels determine it -- its zero-signal K, weighted by errors that describe the
levels' scatter -- else the weighted line, or, where no errors are known or the line fails
its residual check without a curvature term, the unweighted line with offset over the same
levels (Eq. 50's form, so on 0-70 % of saturation it is Eq. 50's K). Where the curve is a
line within its errors the two agree; where it bends, the EMVA K (a line over the bent
range) is below the zero-signal K. ``k_statement`` says which is the
headline, why, and by how much (in combined SE) the two differ -- one sentence shown on the
report, the terminal and the datasheet alike.
"""

from __future__ import annotations

import math

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.physical import resolved

ESTIMATORS = {
    "line": "ARES's weighted line (WLS, each level weighted by 1/se(V)^2)",
    "astier": "the Astier 2019 fit (brighter-fatter curvature)",
    "ols": "the unweighted line with offset (OLS, SE from the residual scatter x Student's t for its n - 2 dof)",
}
EQ50 = ("EMVA 1288 4.0 Linear Section 6.6 Eq. 50 as written (unweighted least squares with offset, "
        "0-70 % of saturation)")


def k_statement(head: Estimate, estimator: str | None, why: str, eq50: Estimate,
                line_chi2_red: float = math.nan) -> dict:
    """``{"headline", "eq50", "difference", "z", "statement"}``: the two K and one sentence.
    ``why``: the reason the headline estimator was chosen (``PtcResult.gain_headline``)."""
    name = ESTIMATORS.get(estimator or "", str(estimator))
    out = {"headline": head.to_dict(), "eq50": eq50.to_dict()}
    if not (head.available and eq50.available):
        missing = "the headline K" if not head.available else "the Eq. 50 K"
        out["statement"] = f"System gain K: {missing} is not available ({(head if not head.available else eq50).note})"
        return out
    diff = head.value - eq50.value
    se = math.hypot(head.se, eq50.se) if math.isfinite(head.se) and math.isfinite(eq50.se) else math.nan
    z = abs(diff) / se if se > 0 else math.nan
    # (a difference whose SE exceeds it is not resolved from 0: only its limit, never "ok" -- ``resolved``)
    out["difference"] = resolved(Estimate(diff, se, head.unit, "headline - Eq. 50 (SE: both SEs combined, their "
                                                               "correlation through the shared levels ignored)"),
                                 "the headline K minus the Eq. 50 K").to_dict()
    out["z"] = z if math.isfinite(z) else None
    if math.isfinite(z) and z > 2:
        cause = ("they weight the same levels differently, and the curve is not a line within its errors"
                 + (f" (line chi2/dof {line_chi2_red:.3g})" if math.isfinite(line_chi2_red) else ""))
    else:
        cause = "consistent within their errors"
    if why.split(":", 1)[0] in ("line", "weighted line", "unweighted line", "linear", "Astier 2019"):
        why = why.split(": ", 1)[-1]  # the estimator is named already
    if abs(diff) <= 1e-9 * abs(eq50.value):  # one fit of the same levels: nothing to compare
        out["statement"] = (f"System gain K: the report's headline is {name}, {head.text()}, because {why}; "
                            f"that is the EMVA 1288 datasheet's K too ({EQ50}): one fit of the same levels.")
        return out
    out["statement"] = (f"System gain K: the report's headline is {name}, {head.text()}, because {why}. The EMVA "
                        f"1288 datasheet's K is {EQ50}, {eq50.text()}. They differ by "
                        f"{Estimate(diff, se, head.unit).text()} ({z:.2g} SE): {cause}.")
    return out
