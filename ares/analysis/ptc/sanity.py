"""Sanity as a verdict (issue 48): a photon-transfer figure that no real sensor gives is
never "ok". Applied to a finished ``PtcResult`` so that every surface (terminal, JSON, CSV,
PDF, GUI) shows the same verdict and reason (``stats.physical.sane``):

- a full well or saturation capacity below 20x the read noise (in e-): a saturation found
  at the first levels, not a sensor's charge capacity (a dynamic range below 26 dB);
- a PTC turnoff below 5 % of the brightest level's signal: the curve was cut at its
  bottom;
- any headline figure whose SE is larger than its value: not measured by these data; a
  K less than 3 SE from 0 (and every figure in e- with it);
- a PTC turnoff (and the saturation capacity, the same level) that the levels' scatter
  cannot identify within ``PRECISION`` (3 %): the plausible last levels on the curve
  (``SaturationBracket.plausible_dn``) span more than that -- the value and its interval
  are in the reason;
- a lower limit ("saturation not reached": no confirmed departure) where the top levels
  fit a turnover more than ``PRECISION`` below the brightest level significantly better
  than one smooth curve: not available, the interval where the curve may turn in the reason;
- a charge (full well, saturation capacity, turnoff in e-) whose K is known only to more
  than ``PRECISION`` / ``PRECISION_SE`` (1.5 %): 2 SE would exceed the 3 % a datasheet
  states it to (generated corpus: 1 % of the "ok" saturation capacities off by > 3 %,
  ``benchmarks/ptc_corpus.md``); and the saturation capacity (turnoff in e-) whose level's
  location and K's 2 SE together, in quadrature, exceed 3 %.

The dynamic range follows its saturation capacity. Pure: no I/O.
"""

from __future__ import annotations

import dataclasses
import math

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.physical import sane

FULL_WELL_MIN_READ_NOISES = 20.0
TURNOFF_MIN_FRACTION = 0.05
PRECISION = 0.03  # a headline turnoff or charge capacity is "ok" only when located to 3 %
PRECISION_SE = 2.0  # ... by its identification, and by K to PRECISION_SE standard errors (K's SE <= 1.5 %)
# (K's SE taken from its own line's residual scatter on few levels already carries Student's t:
# ``headline.gain_estimates``, ``fit.residual_se_widening``)


def _interval(br, charge: bool = False) -> tuple[float, float]:
    """The plausible last levels on the curve (DN): the turnoff's own interval, or with
    ``charge`` the wider one before its low-scatter tightening that a charge at the turnoff
    level is judged on (``turnoff.BEFORE_LOW_NOISE``)."""
    if charge and all(math.isfinite(x) for x in br.charge_plausible_dn):
        return br.charge_plausible_dn
    return br.plausible_dn


def _span(r, charge: bool = False) -> float:
    """How far (relative) the plausible last levels on the curve lie from the turnoff given
    (0 when it is the only one or unknown); ``charge``: on the charge's interval."""
    to, br = r.turnoff_dn, r.saturation
    if not to.available or to.bound or br is None:
        return 0.0
    lo, hi = _interval(br, charge)
    if not (math.isfinite(lo) and math.isfinite(hi)) or to.value <= 0:
        return 0.0
    if hi < to.value:  # a turnover the top levels may fit, with no departure seen (``_turnover_plausible``):
        return 0.0  # it bears on a lower limit only, not on a turnoff that clipped levels beyond it confirm
    return max(to.value - lo, hi - to.value, 0.0) / to.value


def _unlocated(r, charge: bool = False) -> str:
    """Why the turnoff (``charge``: a charge at its level) is not identified within
    ``PRECISION`` ('' when it is)."""
    span = _span(r, charge)
    if span <= PRECISION:
        return ""
    to, (lo, hi) = r.turnoff_dn, _interval(r.saturation, charge)
    return (f"the levels' scatter places the last level on the curve only between {lo:.5g} and {hi:.5g} DN "
            f"({to.value:.5g} most likely, {100 * span:.2g} % away): not located within {100 * PRECISION:g} %")


def _turnover_plausible(r) -> str:
    """Why a lower-limit turnoff ("saturation not reached") is not stated ('' when it may
    be): the top levels fit a kink -- a turnover -- below the brightest level by more than
    ``PRECISION`` significantly better than one smooth curve (``changepoint.rolloff_evidence``)."""
    to, br = r.turnoff_dn, r.saturation
    if not to.available or to.bound != "lower" or br is None:
        return ""
    lo, hi = br.plausible_dn
    if not (math.isfinite(lo) and math.isfinite(hi)) or not lo < (1 - PRECISION) * to.value:
        return ""
    return (f"saturation may be reached: the top levels fall below one smooth curve through all levels (a turnover "
            f"fits them significantly better, by the levels' measured scatter), the curve turning between {lo:.5g} "
            f"and {hi:.5g} DN, so the brightest level ({to.value:.5g} DN) is no lower limit")


def _imprecise(e: Estimate, what: str, k: Estimate, own_se: bool = False, cover: float = PRECISION_SE) -> Estimate:
    """``e`` (a charge, e-) not available when K's relative SE -- or, with ``own_se``, its
    own -- times ``cover`` (``PRECISION_SE``) exceeds ``PRECISION``."""
    if not e.available or e.bound:
        return e
    rel = k.se / k.value if k.available and math.isfinite(k.se) and k.value else 0.0
    why = f"the system gain K is known only to ± {100 * rel:.2g} % here"
    if own_se and math.isfinite(e.se) and e.value and e.se / abs(e.value) > rel:
        rel, why = e.se / abs(e.value), f"it is known only to ± {100 * e.se / abs(e.value):.2g} % (SE)"
    if cover * rel <= PRECISION:
        return e
    return Estimate.na(f"{what} {e.text()}: {why}, so {cover:g} SE exceed the {100 * PRECISION:g} % a charge "
                       "capacity is stated to", e.unit)


def _located_and_measured(e: Estimate, what: str, span: float, k: Estimate, cover: float = PRECISION_SE) -> Estimate:
    """``e`` (a charge at the turnoff level: S / K) not available when its level's location
    (``span``, relative) and K (``PRECISION_SE`` SE) together, in quadrature, exceed
    ``PRECISION``: each alone within it, their errors still add (generated corpus: a level
    2.9 % from the last on the curve and K 1 % low gave a saturation capacity 4 % off)."""
    if not e.available or e.bound or span <= 0:
        return e
    rel = k.se / k.value if k.available and math.isfinite(k.se) and k.value else 0.0
    tot = math.hypot(span, cover * rel)
    if tot <= PRECISION:
        return e
    return Estimate.na(f"{what} {e.text()}: its level is located only to {100 * span:.2g} % and the system gain K to "
                       f"± {100 * rel:.2g} % ({cover:.3g} SE: {100 * tot:.2g} % together), more than the "
                       f"{100 * PRECISION:g} % a charge capacity is stated to", e.unit)


def _unmeasured_gain(r):
    """``r`` with K and every figure in e- not available when K is less than 3 SE from 0
    (the line's own test, applied to whichever model is the headline): no charge is known."""
    k = r.gain_dn_per_e
    if not (k.available and not k.bound and math.isfinite(k.se) and 3 * k.se > abs(k.value)):
        return r
    why = f"the system gain K {k.text()} is less than 3 SE from 0: not measured by these data"

    def na(e: Estimate) -> Estimate:
        return Estimate.na(why, e.unit) if e.available else e

    return dataclasses.replace(
        r, gain_dn_per_e=na(k), gain_e_per_dn=na(r.gain_e_per_dn), conversion_gain_uv_per_e=na(r.conversion_gain_uv_per_e),
        read_noise_e=na(r.read_noise_e), sensitivity_threshold_e=na(r.sensitivity_threshold_e), qe=na(r.qe),
        turnoff_e=na(r.turnoff_e), full_well=na(r.full_well), full_well_e={k_: na(v) for k_, v in r.full_well_e.items()},
        dynamic_range=na(r.dynamic_range), dynamic_range_db=na(r.dynamic_range_db))


def apply(r):
    """``r`` (a ``PtcResult``) with its figures judged; returns a new result."""
    r = _unmeasured_gain(r)
    rn = r.read_noise_e
    floor = FULL_WELL_MIN_READ_NOISES * rn.value if rn.available and not rn.bound else None
    why = f"{FULL_WELL_MIN_READ_NOISES:g}x the read noise ({floor:.3g} e-)" if floor is not None else ""
    fw = {k: sane(v, f"full well ({k})", floor, why) for k, v in r.full_well_e.items()}
    head = sane(r.full_well, "full well", floor, why)
    s_max = max((lv.signal for lv in r.levels if math.isfinite(lv.signal)), default=math.nan)
    t_floor = TURNOFF_MIN_FRACTION * s_max if math.isfinite(s_max) and s_max > 0 else None
    t_why = f"5 % of the brightest level's signal ({t_floor:.4g} DN)" if t_floor is not None else ""
    to_dn = sane(r.turnoff_dn, "PTC turnoff", t_floor, t_why)
    to_e = r.turnoff_e if to_dn.available or not r.turnoff_e.available else Estimate.na(to_dn.note, "e-")
    to_e = sane(to_e, "PTC turnoff (charge)")
    k = r.gain_dn_per_e
    cover = PRECISION_SE
    fw = {k_: _imprecise(v, "saturation capacity" if k_ == "saturation_capacity" else f"full well ({k_})", k,
                         cover=cover) for k_, v in fw.items()}
    head = _imprecise(head, "full well", k, cover=cover)
    to_e = _imprecise(to_e, "PTC turnoff (charge)", k, cover=cover)
    unloc = _unlocated(r)
    turn = _turnover_plausible(r)
    if turn:
        to_dn = Estimate.na(f"PTC turnoff: {turn}", "DN")
        to_e = Estimate.na(to_dn.note, "e-") if to_e.available else to_e
    elif unloc:
        to_dn = Estimate.na(f"PTC turnoff {to_dn.text()}: {unloc}", "DN") if to_dn.available else to_dn
        to_e = Estimate.na(to_dn.note, "e-") if to_e.available else to_e
        sc = fw.get("saturation_capacity")
        if sc is not None and sc.available:
            fw["saturation_capacity"] = Estimate.na(f"saturation capacity {sc.text()} (the turnoff level): {unloc}",
                                                    "e-")
    elif _unlocated(r, charge=True):  # the turnoff located by its tightened interval, its charge not
        unloc = _unlocated(r, charge=True)
        to_e = Estimate.na(f"PTC turnoff (charge) {to_e.text()}: {unloc}", "e-") if to_e.available else to_e
        sc = fw.get("saturation_capacity")
        if sc is not None and sc.available:
            fw["saturation_capacity"] = Estimate.na(f"saturation capacity {sc.text()} (the turnoff level): {unloc}",
                                                    "e-")
    else:
        span = _span(r, charge=True)
        to_e = _located_and_measured(to_e, "PTC turnoff (charge)", span, k, cover)
        sc = fw.get("saturation_capacity")
        if sc is not None:
            fw["saturation_capacity"] = _located_and_measured(sc, "saturation capacity", span, k, cover)
    defs = dict(r.turnoff_definitions_dn)
    if "ptc_turnoff" in defs:
        defs["ptc_turnoff"] = to_dn
    dr, drdb = r.dynamic_range, r.dynamic_range_db
    sat = fw.get("saturation_capacity")
    if sat is not None and not sat.available and dr.available:
        dr, drdb = Estimate.na(sat.note), Estimate.na(sat.note, "dB")
    out = dataclasses.replace(
        r, full_well_e=fw, full_well=head, turnoff_dn=to_dn, turnoff_e=to_e, turnoff_definitions_dn=defs,
        dynamic_range=sane(dr, "dynamic range"), dynamic_range_db=drdb,
        gain_dn_per_e=sane(r.gain_dn_per_e, "system gain K"), gain_e_per_dn=sane(r.gain_e_per_dn, "1/K"),
        conversion_gain_uv_per_e=sane(r.conversion_gain_uv_per_e, "conversion gain"),
        read_noise_dn=sane(r.read_noise_dn, "read noise"), read_noise_e=sane(r.read_noise_e, "read noise"),
        sensitivity_threshold_e=sane(r.sensitivity_threshold_e, "sensitivity threshold"), qe=sane(r.qe, "QE"),
        linearity_error_pct=sane(r.linearity_error_pct, "linearity error"))
    return out
