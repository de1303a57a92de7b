"""The physical-range guard: a figure outside its physical range is never verdict "ok".

Every estimator that makes a figure with a physical bound (a variance or a dark current is
>= 0; an SNR is <= sqrt of the full well in e-) passes it through ``in_range`` where the
Estimate is made, so every surface (CLI, JSON, CSV, PDF, GUI) shows the same verdict:

- inside the range: unchanged;
- outside it but within ``NSIGMA`` standard errors of the bound: only a limit is known --
  an upper limit ``value + NSIGMA * se`` (for a minimum) or a lower limit (for a maximum),
  with the reason;
- further outside (or outside without an SE): not available, with the reason (the model or
  the data do not hold: e.g. correlated noise, drift, the quantization floor).
"""

from __future__ import annotations

import math

from ares.analysis.stats.estimate import Estimate

NSIGMA = 3.0


def in_range(e: Estimate, minimum: float | None = None, maximum: float | None = None, what: str = "",
             bound_se: float = 0.0) -> Estimate:
    """``e`` judged against ``[minimum, maximum]`` (see the module docstring); ``bound_se``:
    the SE of a bound that is itself measured (combined with ``e.se``)."""
    if not e.available:
        return e
    if e.bound:  # a limit on the wrong side of its physical bound is impossible too
        if e.bound == "lower" and maximum is not None and e.value > maximum:
            return Estimate.na(f"{what or 'the value'}: its lower limit {f'{e.value:.3g} {e.unit}'.strip()} is above "
                               f"its physical maximum {maximum:.4g}: the model does not hold for these data", e.unit)
        if e.bound == "upper" and minimum is not None and e.value < minimum:
            return Estimate.na(f"{what or 'the value'}: its upper limit {f'{e.value:.3g} {e.unit}'.strip()} is below "
                               f"its physical minimum {minimum:g}: the model does not hold for these data", e.unit)
        return e
    name = what or "the value"
    se = e.se if math.isfinite(e.se) and e.se > 0 else 0.0
    if math.isfinite(bound_se) and bound_se > 0:
        se = math.hypot(se, bound_se)
    if minimum is not None and e.value < minimum:
        z = (minimum - e.value) / se if se else math.inf
        if z <= NSIGMA:
            return Estimate.limit(e.value + NSIGMA * se, "upper", e.unit,
                                  f"{name} {e.value:.3g} is below its physical minimum {minimum:g} by {z:.2g} SE: "
                                  f"only an upper limit (value + {NSIGMA:g} SE)")
        return Estimate.na(f"{name} {e.value:.3g} {e.unit} is {'far' if not se else f'{z:.3g} SE'} below its "
                           f"physical minimum {minimum:g}: the model does not hold for these data", e.unit)
    if maximum is not None and e.value > maximum:
        z = (e.value - maximum) / se if se else math.inf
        if z <= NSIGMA:
            return Estimate.limit(e.value - NSIGMA * se, "lower", e.unit,
                                  f"{name} {e.value:.3g} is above its physical maximum {maximum:.4g} by {z:.2g} SE: "
                                  f"only a lower limit (value - {NSIGMA:g} SE)")
        return Estimate.na(f"{name} {e.value:.3g} {e.unit} is {'far' if not se else f'{z:.3g} SE'} above its "
                           f"physical maximum {maximum:.4g}: the model does not hold for these data", e.unit)
    return e


VARIANCE_COMPONENTS = ("Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global")


def variances_in_range(components: dict[str, Estimate]) -> dict[str, Estimate]:
    """The variance components of a decomposition (DN^2) judged against >= 0 -- and, being
    figures whose truth may be 0 (a frame-global or row-temporal term a sensor need not have),
    one whose SE exceeds it is an upper limit (``resolved``, a variance's side), never "ok"."""
    return {k: resolved(in_range(e, minimum=0.0, what=f"variance {k}"), f"variance {k}", side="upper")
            if k in VARIANCE_COMPONENTS
            else e for k, e in components.items()}


def snr_in_range(snr: Estimate, charge: float, what: str = "SNR", of: str = "the full well",
                 charge_se: float = 0.0) -> Estimate:
    """An SNR judged against its physical maximum sqrt(``charge``): shot noise alone gives
    SNR = sqrt(N) for N collected charges (or N photons for an ideal detector, QE = 1), and
    every other noise lowers it, so an SNR above sqrt of the well (of the photons) means the
    noise or the charge was mis-measured (e.g. a collapsed variance beyond saturation, a QE
    above 1). No bound is applied when ``charge`` is not a positive finite number."""
    if not (isinstance(charge, (int, float)) and math.isfinite(charge) and charge > 0):
        return snr
    bse = 0.5 * charge_se / math.sqrt(charge) if math.isfinite(charge_se) else 0.0
    return in_range(snr, maximum=math.sqrt(charge), what=f"{what} (at most sqrt of {of}, {charge:.4g})",
                    bound_se=bse)


def snr_db(snr: Estimate, note: str = "20 log10 SNR") -> Estimate:
    """``snr`` in dB with the same verdict (a limit stays a limit, not available stays so)."""
    if not snr.available:
        return Estimate.na(snr.note, "dB")
    if snr.value <= 0:
        return Estimate.na(f"SNR {snr.value:.3g} is not positive", "dB")
    db = 20 * math.log10(snr.value)
    if snr.bound:
        return Estimate.limit(db, snr.bound, "dB", f"{note}; {snr.note}")
    se = 20 / math.log(10) * snr.se / snr.value if math.isfinite(snr.se) else math.nan
    return Estimate(db, se, "dB", note)


def sane(e: Estimate, what: str = "", floor: float | None = None, floor_why: str = "") -> Estimate:
    """``e`` unless it fails a sanity bound, then not available with the reason (issue 48):
    an SE larger than the value (the figure is not measured), or a value below ``floor``
    (``floor_why`` names the bound, e.g. "20x the read noise"). Limits and figures already
    not available pass unchanged."""
    if not e.available or e.bound:
        return e
    name = what or "the value"
    if math.isfinite(e.se) and e.se > abs(e.value):
        return Estimate.na(f"{name} {e.value:.3g} ± {e.se:.2g} {e.unit}: its SE is larger than the value, so it is "
                           "not measured by these data", e.unit)
    if floor is not None and math.isfinite(floor) and e.value < floor:
        return Estimate.na(f"{name} {e.value:.4g} {e.unit} is below {floor_why or f'{floor:.4g}'}: not a credible "
                           f"{what or 'value'} (a turnoff or saturation found too early)", e.unit)
    return e


def resolved(e: Estimate, what: str = "", side: str | None = None) -> Estimate:
    """A figure whose true value may be 0 (image lag, an INL/DNL extreme, a charge-transfer
    trend, a variance component) with an SE larger than its distance from 0 is not resolved
    from 0: never "ok" (issue 48), only the limit the data give, with the reason. ``side``
    says which limit:

    - ``"upper"``: the figure cannot be below 0 (a variance, a maximum of a curve that
      crosses 0): resolved only when value > SE; else the upper limit value + ``NSIGMA`` SE,
      whatever the sign of the value (a non-negative quantity measured -0.1 ± 0.5 is < 1.4);
    - ``"lower"``: the mirror (a minimum of such a curve): resolved only when value < -SE;
      else the lower limit value - ``NSIGMA`` SE;
    - ``None`` (default): a signed figure whose truth may be either side of 0: resolved when
      SE <= |value|; else the limit away from 0 on the value's side -- value + ``NSIGMA`` SE
      (upper) for a value >= 0, value - ``NSIGMA`` SE (lower) for a negative one.

    (``sane`` makes such a figure not available instead: right for a figure that is never
    near 0, like a gain; here "consistent with 0, below x" is the measurement.)"""
    if side not in (None, "upper", "lower"):
        raise ValueError(f"resolved: side must be None, 'upper' or 'lower', not {side!r}")
    if not e.available or e.bound or not math.isfinite(e.se):
        return e
    away = e.value if side == "upper" else -e.value if side == "lower" else abs(e.value)
    if e.se <= away:
        return e
    name = what or "the value"
    why = f"{name} {e.value:.3g} ± {e.se:.2g} {e.unit}".rstrip() + ": not resolved from 0 (" + (
        "its SE is larger than the value)" if side is None else
        f"it cannot be {'below' if side == 'upper' else 'above'} 0, and its SE is not below its distance from 0)")
    if side == "upper" or (side is None and e.value >= 0):
        return Estimate.limit(e.value + NSIGMA * e.se, "upper", e.unit, f"{why}: only an upper limit (value + "
                                                                           f"{NSIGMA:g} SE)")
    return Estimate.limit(e.value - NSIGMA * e.se, "lower", e.unit, f"{why}: only a lower limit (value - {NSIGMA:g} SE)")
