"""Saturation, the PTC turnoff and full-well criteria. Each returns a level index (or -1).

- ``index_max_variance``: EMVA 1288 Release 3.0 -- the level of maximum temporal
  variance, searched from the brightest level down so that noise spikes above the
  peak are skipped (the reference implementation's rule; used by the reference set).
- ``index_max_code``: EMVA 1288 Release 4.0 Linear, Section 6.6 (histogram criterion) --
  the highest level, before the first violation, with no more than ``limit`` (0.2 %) of
  the samples at the maximum code.
- ``ptc_turnoff`` (``ares.analysis.ptc.turnoff``): the headline turnoff -- the curve
  followed from below up to its first confirmed departure.
- ``index_variance_drop``: LSST-style turnoff -- the level before the first level-to-level
  drop of the variance.
- ``saturation_bracket``: saturation lies between the last unclipped level and the first
  clipped one; every full-well definition is checked against that bracket.
- ``index_linearity_turnoff``: last level before the first above the linearity fit range
  that deviates more than ``tol`` (1 %) from a line of signal vs exposure (or photons).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from typing import Sequence
from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.median import fast_median


def index_max_variance(var) -> int:
    var = np.asarray(var, float)
    n = var.size
    if n == 0:
        return -1
    best, best_i = 0.0, 0
    for i in range(n - 1, -1, -1):
        prev = var[abs(i - 1)]
        if var[i] >= best or prev >= best:
            best, best_i = var[i], i
        elif var[i] < best and prev < best:
            break
    return best_i


def index_max_code(frac_at_max, limit: float = 0.002) -> int:
    f = np.asarray(frac_at_max, float)
    bad = np.nonzero(f > limit)[0]
    if bad.size == 0:
        return f.size - 1
    return int(bad[0]) - 1


# ----------------------------------------------------------------------- PTC turnoff
# (``ptc_turnoff`` lives in ``ares.analysis.ptc.turnoff``, with the errors it decides on)

def index_variance_drop(var) -> int:
    """LSST-style turnoff (the photon-transfer "pivot" of LSST's calibration pipeline, as
    commonly described): in signal order, the level before the first level whose variance
    is lower than the level below it; the last level when the variance never drops."""
    v = np.asarray(var, float)
    if v.size == 0:
        return -1
    drops = np.flatnonzero(np.diff(v) < 0)
    return int(drops[0]) if drops.size else v.size - 1


# ----------------------------------------------------------------- saturation bracket

@dataclass(frozen=True)
class SaturationBracket:
    """Saturation lies between level ``last_ok`` (on the curve, <= the clip limit at the
    maximum code) and level ``first_clipped`` (the next brighter level, clipped or rolled
    off). ``low_dn``/``high_dn`` bound the saturation signal (DN, dark subtracted): the
    last unclipped level's signal, and the first clipped level's *nominal* signal (its
    illumination times the response below saturation; NaN without an illumination axis).
    ``reached`` is False when no level beyond ``last_ok`` shows clipping."""

    reached: bool
    last_ok: int  # input index, -1 when no level is usable
    first_clipped: int  # input index, -1 when saturation is not reached
    low_dn: float
    high_dn: float
    reason: str  # one sentence: how the bracket was found, or why saturation is not reached
    seen_dn: float = math.nan  # the signal at which the turnoff's departure was seen (above the turnoff)
    # the signals of the first and last level that may be the last on the curve, given the
    # levels' scatter (``turnoff.ptc_turnoff_found``): the turnoff's identification
    plausible_dn: tuple[float, float] = (math.nan, math.nan)
    # the same before the turnoff's low-scatter tightening: what a charge at the turnoff
    # level (the saturation capacity) is judged on (NaN: ``plausible_dn``)
    charge_plausible_dn: tuple[float, float] = (math.nan, math.nan)

    def contains(self, signal_dn: float, slack: float = 0.0) -> bool:
        """Is ``signal_dn`` consistent with the bracket (``slack`` DN either side)?"""
        if not self.reached:
            return signal_dn <= self.low_dn + slack
        hi = self.high_dn if math.isfinite(self.high_dn) else math.inf
        return self.low_dn - slack <= signal_dn <= hi + slack


def saturation_bracket(signal, clipped, on_curve, nominal=None) -> SaturationBracket:
    """``signal`` per level (DN); ``clipped[i]``: level i shows clipping (samples at the
    maximum code above the limit, collapsed variance, or rolled off the PTC);
    ``on_curve[i]``: level i is a usable level on the photon-transfer curve; ``nominal``:
    the illumination axis (photons or exposure), used for the bracket's upper end."""
    s = np.asarray(signal, float)
    clipped = np.asarray(clipped, bool)
    ok = np.asarray(on_curve, bool) & ~clipped
    if not ok.any():
        return SaturationBracket(False, -1, -1, math.nan, math.nan, "no usable level on the photon-transfer curve")
    last = int(np.flatnonzero(ok)[np.argmax(s[ok])])
    above = clipped & np.isfinite(s) & (s > 0)
    if nominal is not None:
        x = np.asarray(nominal, float)
        above &= x > x[last]
    else:
        x = None
        above &= s >= s[last]
    if not above.any():
        return SaturationBracket(False, last, -1, float(s[last]), math.nan,
                                 f"saturation not reached: the brightest usable level ({s[last]:.5g} DN) is still on "
                                 "the photon-transfer curve and no brighter level is clipped")
    cand = np.flatnonzero(above)
    first = int(cand[np.argmin(x[cand])]) if x is not None else int(cand[np.argmin(s[cand])])
    if x is not None and x[last] > 0 and math.isfinite(x[first]):
        high = float(s[last] * x[first] / x[last])
        how = (f"saturation between {s[last]:.5g} DN (last unclipped level) and {high:.5g} DN "
               "(first clipped level, at its illumination times the response below)")
    else:
        high = math.nan
        how = f"saturation above {s[last]:.5g} DN (last unclipped level); the next brighter level is clipped"
    return SaturationBracket(True, last, first, float(s[last]), high, how)


# ------------------------------------------------------------------------ linearity

def index_linearity_turnoff(x, signal, tol: float = 0.01, fit_lo: float = 0.05,
                            fit_hi: float = 0.5) -> int:
    """Last index (in increasing ``x``) before the first level above the fit range that
    deviates > ``tol`` from a line fitted over levels between ``fit_lo`` and ``fit_hi`` of
    the maximum signal. Levels below the top of the fit range are not searched: their
    deviations (offset residue, quantization at a few DN) are the linearity error's
    business, not the turnoff's -- a 1 % rule applied there stops at the first dim level."""
    x = np.asarray(x, float)
    s = np.asarray(signal, float)
    fin = np.isfinite(x) & np.isfinite(s)
    if fin.sum() < 2:
        return -1
    smax = np.max(s[fin])
    sel = fin & (s >= fit_lo * smax) & (s <= fit_hi * smax)
    if sel.sum() < 2 or np.ptp(x[sel]) == 0:  # a line needs two distinct illuminations
        return -1
    a, b = np.polyfit(x[sel], s[sel], 1)
    pred = a * x + b
    dev = np.abs(s - pred) / np.maximum(np.abs(pred), 1e-12)
    top_x = x[sel].max()
    last = -1
    for i in np.argsort(x):
        if not fin[i]:
            continue
        if x[i] > top_x and dev[i] > tol:
            break
        last = int(i)
    return last


def _full_well(levels: list[PtcLevel], br: SaturationBracket, gain: Estimate, clip_limit: float,
               xlin, photons) -> tuple[dict[str, Estimate], Estimate, int]:
    """Every full-well definition, each consistent with the saturation bracket or not
    available saying why; the headline full well; the EMVA 3.0 saturation index."""
    fw: dict[str, Estimate] = {}
    na_sat = br.reason if not br.reached else ""
    k = gain

    def charge(s_dn: float, note: str, extra_se_dn: float = 0.0) -> Estimate:
        if not k.available:
            return Estimate.na("gain not available", "e-")
        v = s_dn / k.value
        return Estimate(v, math.hypot(v * k.se / k.value, extra_se_dn / k.value), "e-", note)

    def checked(i: int, note: str) -> Estimate:
        if i < 0:
            return Estimate.na("not found in the data", "e-")
        s = levels[i].signal
        if not br.reached:
            return Estimate.na(na_sat, "e-")
        if not br.contains(s):
            return Estimate.na(f"level {i} ({s:.5g} DN) is outside the saturation bracket: {br.reason}", "e-")
        return charge(s, note)

    good = [lv for lv in levels if math.isfinite(lv.signal) and math.isfinite(lv.variance) and lv.signal > 0
            and not lv.reason.startswith(("non-monotonic", "no significant", "non-finite"))]
    good.sort(key=lambda lv: lv.signal)
    # EMVA 3.0: the level of maximum temporal variance (global maximum over the levels in
    # signal order: a collapsed plateau's variance is noise around 0, not a series to walk)
    sat_i = good[int(np.argmax([lv.variance for lv in good]))].index if good else -1
    fw["saturation_capacity"] = checked(br.last_ok, "EMVA 1288 4.0: the last level on the curve with <= "
                                                    f"{100 * clip_limit:g} % of samples clipped; {br.reason}")
    fw["max_variance"] = checked(sat_i, "EMVA 1288 3.0: signal at the level of maximum temporal variance")
    if not any(lv.frac_at_max > 0 for lv in good):
        fw["max_code"] = Estimate.na("no level reaches the ADC maximum code (see 'plateau')", "e-")
    else:
        im = index_max_code([lv.frac_at_max for lv in good], clip_limit)
        fw["max_code"] = checked(good[im].index if im >= 0 else -1,
                                 f"EMVA 1288 4.0: highest level with <= {100 * clip_limit:g} % of pixels at max code")
    fw["plateau"] = _plateau(levels, br, k)
    # (the PTC turnoff is not a full-well definition here: it is one figure, turnoff_dn /
    # turnoff_e, whose SE says it is located only to within the level spacing -- issue 34)
    if xlin is not None:
        on = [lv for lv in levels if lv.status != "excluded" or lv.clipped]
        xs = np.asarray(xlin, float)
        il = index_linearity_turnoff(xs[[lv.index for lv in on]], [lv.signal for lv in on])
        if il >= 0 and on[il].index == br.last_ok and not br.reached:
            fw["linearity_1pct"] = Estimate.na("no level deviates more than 1 % from the line: " + na_sat, "e-")
        else:
            fw["linearity_1pct"] = checked(on[il].index if il >= 0 else -1,
                                           "last level within 1 % of a line of signal vs "
                                           + ("photons" if photons is not None else "exposure"))
    else:
        fw["linearity_1pct"] = Estimate.na("needs exposure or photon count per level", "e-")
    if br.reached and math.isfinite(br.high_dn):
        mid, half = (br.low_dn + br.high_dn) / 2, (br.high_dn - br.low_dn) / 2
        fw["bracket"] = charge(mid, f"centre of the saturation bracket, SE from its width/sqrt(3); {br.reason}",
                               half / math.sqrt(3))
    else:
        fw["bracket"] = Estimate.na(br.reason if not br.reached else "no illumination axis for the upper end", "e-")
    if fw["plateau"].available:
        head = fw["plateau"]
    elif fw["bracket"].available:
        head = fw["bracket"]
    elif br.reached and k.available:
        head = Estimate.limit(br.low_dn / k.value, "lower", "e-", br.reason)
    else:
        head = Estimate.na(na_sat or "gain not available", "e-")
    return fw, head, sat_i


TURNOFF_NOTE = ("PTC turnoff: the last level of the curve followed from below before its first significant "
                "departure (variance/mean ratio or variance dropping by > 4 SE); located only to within the "
                "level spacing: SE = spacing to the next level / sqrt(3)")


def _turnoffs(levels: Sequence[PtcLevel], br: SaturationBracket, gain: Estimate,
              clip_limit: float) -> tuple[Estimate, Estimate, dict[str, Estimate]]:
    """The headline turnoff in DN and e- (``ptc_turnoff``), and the published definitions
    by name in DN, each the signal of one level with the level spacing there as its SE."""
    meas = sorted((lv for lv in levels if math.isfinite(lv.signal) and math.isfinite(lv.variance) and lv.signal > 0
                   and not lv.reason.startswith(("non-monotonic", "no significant", "non-finite"))),
                  key=lambda lv: lv.signal)
    pos = {lv.index: j for j, lv in enumerate(meas)}

    def at(i: int, note: str, bound: str = "", top_is_limit: bool = False) -> Estimate:
        if i < 0 or i not in pos:
            return Estimate.na("not found in the data", "DN")
        j = pos[i]
        s = meas[j].signal
        if top_is_limit and j == len(meas) - 1 and not bound:  # a definition that found nothing beyond the
            bound, note = "lower", f"{note}; a lower limit: the brightest level, nothing beyond it"  # brightest level
        if bound:
            return Estimate.limit(s, bound, "DN", note)
        nxt = [lv.signal for lv in meas[j + 1:] if lv.signal > s]
        # the level found is the last one before the departure: the turnoff itself lies
        # anywhere between it and the next level, so its error is the rms distance from this
        # level to a point uniform in that interval, spacing/sqrt(3) (not the signal's own SE,
        # which is ~1000x smaller and says nothing about where the curve turns). Where the
        # departure was seen only levels later (a gradual roll-off in noisy levels), the
        # turnoff lies anywhere up to there: the interval is that wide (issue 48)
        top = max(nxt[0] if nxt else math.nan, br.seen_dn if i == br.last_ok and br.seen_dn > s else -math.inf)
        return Estimate(s, (top - s) / math.sqrt(3) if math.isfinite(top) else math.nan, "DN", note)

    if br.last_ok < 0:
        head = Estimate.na(br.reason, "DN")
    elif br.reached:
        head = at(br.last_ok, TURNOFF_NOTE)
    else:
        head = at(br.last_ok, f"a lower limit: {br.reason}", "lower")
    if head.available and gain.available:
        v = head.value / gain.value
        se = (v * math.hypot(head.se / head.value if math.isfinite(head.se) else 0.0, gain.se / gain.value)
              if not head.bound else math.nan)
        head_e = Estimate(v, se, "e-", head.note, head.bound)
    else:
        head_e = Estimate.na(head.note if not head.available else "gain not available", "e-")
    var = [lv.variance for lv in meas]
    idx = [lv.index for lv in meas]
    im = index_max_code([lv.frac_at_max for lv in meas], clip_limit)
    defs = {
        "ptc_turnoff": head,
        "emva4_saturation": at(idx[im] if im >= 0 and meas else -1, "EMVA 1288 4.0 Section 6.6: the highest level "
                               f"before the first with > {100 * clip_limit:g} % of samples at the maximum code",
                               top_is_limit=True),
        "max_variance": at(idx[int(np.argmax(var))] if meas else -1,
                           "EMVA 1288 3.0: the level of maximum temporal variance", top_is_limit=True),
        "lsst_turnoff": at(idx[index_variance_drop(var)] if meas else -1,
                           "LSST-style: the level before the first level-to-level drop of the variance",
                           top_is_limit=True),
    }
    return head, head_e, defs


def _plateau(levels: Sequence[PtcLevel], br: SaturationBracket, gain: Estimate) -> Estimate:
    """Full well from the saturated plateau: the dark-subtracted signal of the levels
    beyond saturation whose temporal variance has collapsed (every pixel clipped at its
    full-well charge) -- the charge capacity itself, not the last level below it."""
    if not br.reached:
        return Estimate.na(br.reason, "e-")
    if not gain.available:
        return Estimate.na("gain not available", "e-")
    vpk = max(lv.variance for lv in levels if lv.status != "excluded" or lv.clipped)
    top = [lv for lv in levels if lv.clipped and lv.signal > br.low_dn and lv.variance < 0.1 * vpk]
    if not top:
        return Estimate.na("no level beyond saturation with collapsed variance (all pixels clipped)", "e-")
    smax = max(lv.signal for lv in top)
    top = [lv for lv in top if lv.signal >= 0.995 * smax]
    if fast_median(np.array([lv.frac_at_max for lv in top])) > 0.5:
        return Estimate.na("the plateau is at the ADC maximum code: ADC-limited, not the pixel full well", "e-")
    sv = np.array([lv.signal for lv in top])
    med = float(fast_median(sv))
    if not br.contains(med):
        return Estimate.na(f"the plateau ({med:.5g} DN) is outside the saturation bracket: {br.reason}", "e-")
    v = med / gain.value
    spread = float(np.std(sv, ddof=1) / math.sqrt(sv.size)) / gain.value if sv.size > 1 else 0.0
    return Estimate(v, math.hypot(spread, v * gain.se / gain.value), "e-",
                    f"saturated plateau: median signal of {sv.size} fully clipped level(s) / K")


@dataclass(frozen=True)
class PtcLevel:
    index: int  # position in the input
    signal: float  # DN, dark subtracted
    variance: float  # DN^2, dark subtracted
    variance_se: float
    dof: float
    total_var: float  # DN^2, bright temporal variance (dark not subtracted), for SNR
    spatial_var: float  # DN^2, spatial variance of the level (temporal part removed)
    frac_at_max: float
    exposure_s: float = math.nan
    photons: float = math.nan
    status: str = "fit"  # "fit" | "valid" | "excluded"
    reason: str = ""
    clipped: bool = False  # evidence of saturation (clipped, collapsed or rolled off)
    decision_se: float = math.nan  # DN^2: the variance error the decisions used (``turnoff.decision_errors``)
    signal_se: float = math.nan  # DN: the signal's SE (frame means' scatter, else the temporal noise / sqrt(N))
