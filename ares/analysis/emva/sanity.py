"""The last word on an EMVA 1288 table's figures (Linear, General, Release 3.0/3.1): what no
measurement can give is never verdict "ok" (issue 48).

- a dark current (``mu_I_*``, ``u_I_*``) below zero: judged against its physical minimum
  (``ares.analysis.stats.physical.in_range``: an upper limit within 3 SE, else not available);
- a dark current whose charge over the longest exposure exceeds the saturation capacity
  (the dark signal would have saturated the pixel): not available, with the numbers;
- a figure whose SE is larger than its value: not determined -- a dark current becomes the
  upper limit value + SE (the one EMVA 1288 4.0 Section 7.1 asks for beside it), anything
  else "not available" with the value and SE in the reason.
"""

from __future__ import annotations

import math

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.physical import in_range

RATES = ("mu_I_mean", "mu_I_var", "u_I_mean", "u_I_var")


def judge(values: dict[str, Estimate], *, saturation: Estimate | None = None,
          longest_exposure_s: float | None = None) -> dict[str, Estimate]:
    """``values`` judged (module docstring); ``saturation``: the saturation capacity in the
    rates' charge unit (e- for Linear and 3.0, photons for General)."""
    out = {}
    for k, e in values.items():
        if not isinstance(e, Estimate) or not e.available:
            out[k] = e
            continue
        if k in RATES:
            e = in_range(e, 0.0, what="dark current")
            e = _within_saturation(e, saturation, longest_exposure_s)
        if e.available and not e.bound and math.isfinite(e.se) and e.se > abs(e.value) and e.value != 0:
            why = f"{e.value:.3g} ± {e.se:.2g} {e.unit}".rstrip() + ": the SE is larger than the value"
            e = (Estimate.limit(e.value + e.se, "upper", e.unit, f"{why}; only the upper limit value + SE "
                                                               "(EMVA 1288 4.0 Section 7.1)")
                 if k in RATES and e.value + e.se > 0 else Estimate.na(f"{why}: not determined by these data", e.unit))
        out[k] = e
    return out


def _within_saturation(e: Estimate, sat: Estimate | None, t_max: float | None) -> Estimate:
    if not (e.available and sat is not None and sat.available and sat.value > 0 and t_max and t_max > 0):
        return e
    charge = e.value * t_max
    if e.bound != "upper" and charge > sat.value:
        return Estimate.na(f"dark current {e.value:.3g} {e.unit} would collect {charge:.3g} over the longest exposure "
                           f"({t_max:.3g} s), above the saturation capacity {sat.value:.4g}: physically impossible "
                           "(the dark signal's slope does not measure a dark current here)", e.unit)
    return e
