"""Sanity as a verdict (issue 48): a photon-transfer figure that no real sensor gives is
never "ok". Applied to a finished ``PtcResult`` so that every surface (terminal, JSON, CSV,
PDF, GUI) shows the same verdict and reason (``stats.physical.sane``):

- a full well or saturation capacity below 20x the read noise (in e-): a saturation found
  at the first levels, not a sensor's charge capacity (a dynamic range below 26 dB);
- a PTC turnoff below 5 % of the brightest level's signal: the curve was cut at its
  bottom;
- any headline figure whose SE is larger than its value: not measured by these data.

The dynamic range follows its saturation capacity. Pure: no I/O.
"""

from __future__ import annotations

import dataclasses
import math

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.physical import sane

FULL_WELL_MIN_READ_NOISES = 20.0
TURNOFF_MIN_FRACTION = 0.05


def apply(r):
    """``r`` (a ``PtcResult``) with its figures judged; returns a new result."""
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
