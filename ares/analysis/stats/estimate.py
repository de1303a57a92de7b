"""A value with its standard error, unit and verdict -- the currency of every result.

The judgment layer between the estimators and everything that shows a number (CLI, JSON,
CSV, PDF, GUI):

- ``Estimate(value, se, unit, note)``: an available figure, ``note`` says how it was made;
- ``Estimate.na(reason)``: the figure's preconditions failed (one frame, dark only,
  saturation not reached, the model does not fit ...). It is reported as *not available*
  with ``reason``, never as a number and never as 0;
- ``Estimate.bound(value, "upper"|"lower", reason)``: only a limit is known (e.g. EMVA 1288
  4.0 Linear Eq. 54, read noise below the quantization floor);
- ``Estimate.declared(value, unit, why, note)``: an exact value, SE 0, because it is declared,
  not measured (the photons of a step, a gain the user gives). It is shown with its verdict
  "(exact: why)" (``exact_text``, the one wording) where another figure shows "± SE"; its
  uncertainty (a photon calibration's) is not this evaluation's to state, so none is invented;
  ``Estimate.count(n, unit)`` the same for a count ("exact: counted": exact by nature).

``format_value`` is the one place that decides how many digits a figure gets: the SE is
rounded to two significant digits and the value to the SE's last digit (ISO GUM 7.2.6), so
"0.28 ± 8.3e-05" is shown as "0.280769 ± 0.000083". Every surface calls it (through ``str``/``format`` of an ``Estimate``, or ``format_dict`` on the JSON form).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

VERDICT_OK = "ok"
VERDICT_NA = "not available"
VERDICT_UPPER = "upper limit"
VERDICT_LOWER = "lower limit"
EXACT_DEFAULT = "declared, not measured"  # an SE of exactly 0 that came without its reason
EXACT_PHOTONS = "declared photons"  # a step's photons: the bench's or the data set's, not this evaluation's
EXACT_PHOTONS_AREA = "declared photons and pixel area"
EXACT_GAIN = "gain given, not measured"
EXACT_COUNT = "counted"  # a count of pixels (columns, rows, ...): exact by nature, no SE to state
EXACT_PREFIX = "exact: "


def exact_text(why: str = "") -> str:
    """The verdict shown beside a figure whose SE is exactly 0 (every surface: this wording)."""
    return f"{EXACT_PREFIX}{why or EXACT_DEFAULT}"


def exact_why(verdict: str) -> str:
    """The why of a verdict column written by ``exact_text`` ("" for any other verdict): a
    table that keeps only the verdict (lot.csv, the results database) gives it back."""
    return verdict[len(EXACT_PREFIX):] if (verdict or "").startswith(EXACT_PREFIX) else ""


@dataclass(frozen=True)
class Estimate:
    value: float
    se: float = math.nan
    unit: str = ""
    note: str = ""
    bound: str = ""  # "" (an estimate), "upper" or "lower" (only a limit is known)
    exact: str = ""  # why the SE is exactly 0 ("declared photons"): see ``declared``

    @classmethod
    def na(cls, reason: str, unit: str = "") -> "Estimate":
        return cls(math.nan, math.nan, unit, reason)

    @classmethod
    def limit(cls, value: float, which: str, unit: str, reason: str) -> "Estimate":
        if which not in ("upper", "lower"):
            raise ValueError(f"a limit is 'upper' or 'lower', not {which!r}")
        return cls(float(value), math.nan, unit, reason, which)

    @classmethod
    def declared(cls, value: float, unit: str, why: str, note: str = "") -> "Estimate":
        """An exact value (SE 0): declared, not measured; ``why`` in a few words ("declared photons")."""
        return cls(float(value), 0.0, unit, note, "", why)

    @classmethod
    def count(cls, n: int, unit: str, note: str = "") -> "Estimate":
        """A count (defect pixels, masked pixels): exact, SE 0, shown "8 pixels (exact: counted)"."""
        return cls(float(int(n)), 0.0, unit, note, "", EXACT_COUNT)

    @property
    def is_exact(self) -> bool:
        """SE exactly 0 on an available estimate (declared, or derived from declared values only)."""
        return self.available and self.se == 0 and not self.bound

    @property
    def available(self) -> bool:
        return math.isfinite(self.value)

    @property
    def verdict(self) -> str:
        if not self.available:
            return VERDICT_NA
        return {"upper": VERDICT_UPPER, "lower": VERDICT_LOWER}.get(self.bound, VERDICT_OK)

    def to_dict(self) -> dict:
        d = {
            "value": self.value if self.available else None,
            "se": self.se if math.isfinite(self.se) and self.available else None,
            "unit": self.unit,
            "verdict": self.verdict,
        }
        if self.note:
            d["note"] = self.note
        if self.is_exact:
            d["exact"] = self.exact or EXACT_DEFAULT
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Estimate":
        v = d.get("value")
        se = d.get("se")
        bound = {VERDICT_UPPER: "upper", VERDICT_LOWER: "lower"}.get(d.get("verdict", ""), "")
        return cls(math.nan if v is None else float(v), math.nan if se is None else float(se),
                   d.get("unit", ""), d.get("note", ""), bound,
                   "" if d.get("exact") == EXACT_DEFAULT else d.get("exact", ""))  # (round trip: the same Estimate)

    def text(self, with_unit: bool = True, with_reason: bool = False, with_exact: bool = True) -> str:
        """``12002 ± 3.6 e-``; ``< 0.40 e-`` (upper limit); ``15320 photons (exact: declared
        photons)`` (SE 0; ``with_exact=False``: a layout that states the verdict on its own line
        or column); ``n/a`` (+ the reason)."""
        if not self.available:
            return "n/a" + (f" ({self.note})" if with_reason and self.note else "")
        if self.is_exact:  # all its digits (a declared count is not rounded), then its verdict
            return format_value(self.value, None, EXACT_DIGITS) + (f" {self.unit}" if with_unit and self.unit else "") \
                + (f" ({exact_text(self.exact)})" if with_exact else "")
        s = format_value(self.value, self.se)
        if self.bound:
            s = ("< " if self.bound == "upper" else "> ") + s
        return s + (f" {self.unit}" if with_unit and self.unit else "")

    def __format__(self, spec: str) -> str:
        if spec:  # an explicit format (plots, fixed-width tables)
            if not self.available:
                return "n/a"
            s = format(self.value, spec)
            if self.is_exact:
                return f"{s} ({exact_text(self.exact)})"
            return s + (" ± " + format(self.se, spec) if math.isfinite(self.se) else "")
        return self.text(with_unit=False)

    def __str__(self) -> str:
        return self.text()


EXACT_DIGITS = 7  # an exact value's significant digits (a declared photon count up to 10^7 in full)


def _decimals_for(se: float) -> int:
    """Decimal places that keep two significant digits of ``se`` (may be negative)."""
    return 1 - int(math.floor(math.log10(abs(se))))


def format_value(value, se=None, sig: int = 4) -> str:
    """``value ± se`` with the digits the SE supports (two significant digits of the SE,
    the value rounded to the same place); without a finite SE, ``sig`` significant digits.
    Very large or small magnitudes use a shared exponent: ``(1.2003 ± 0.0036)e+04``."""
    if value is None or not math.isfinite(value):
        return "n/a"
    value = float(value)
    if se is None or not math.isfinite(se) or se <= 0:
        return f"{value:.{sig}g}"
    se = float(se)
    mag = max(abs(value), se)
    exp = int(math.floor(math.log10(mag))) if mag > 0 else 0
    if -3 <= exp < 6:
        d = _decimals_for(se)
        if d <= 0:  # the SE's digits are left of the point: round, print as integers
            q = 10 ** (-d)
            return f"{round(value / q) * q:.0f} ± {round(se / q) * q:.0f}"
        return f"{value:.{d}f} ± {se:.{d}f}"
    scale = 10.0 ** exp
    d = max(_decimals_for(se / scale), 0)
    return f"({value / scale:.{d}f} ± {se / scale:.{d}f})e{exp:+03d}"


def note_text(d: dict) -> str:
    """A table's note/definition column (CSV, HDF5) for the JSON form of an estimate: an
    exact figure's verdict first (its value column holds the number, its SE column 0)."""
    note = d.get("note") or ""
    return f"{exact_text(d['exact'])}; {note}" if d.get("exact") and note else \
        exact_text(d["exact"]) if d.get("exact") else note


def format_dict(d, with_unit: bool = True, with_reason: bool = False) -> str:
    """The same text for the JSON form of an estimate (``Estimate.to_dict``)."""
    if not isinstance(d, dict):
        return "n/a"
    text = Estimate.from_dict(d).text(with_unit, with_reason)
    v = d.get("verdict")  # a verdict an Estimate does not hold ("drift not separated"): never shown as if "ok"
    if v and v not in (VERDICT_OK, VERDICT_NA, VERDICT_UPPER, VERDICT_LOWER) and d.get("value") is not None:
        text += f" -- not ok: {v}"
    return text


# The relative gain spreads of the 13-component model (variances of G·Cg, G·Rg, G·Pg over G):
# every surface shows them as % rms, the datasheet's unit; JSON/CSV/HDF5 keep the variance.
GAIN_SPREADS = ("Cg", "Rg", "Pg")


def pct_rms(relative_variance: float) -> float:
    """A gain spread's relative variance as % rms (NaN below 0: no rms to show)."""
    v = float(relative_variance)
    return 100 * math.sqrt(v) if v >= 0 else math.nan


LIMIT_NSIGMA = 3.0  # a limit is the value + 3 SE (``stats.physical.NSIGMA``: one rule on every surface)


def component_display(c: str, d: dict) -> tuple[str, str]:
    """(value ± SE, unit) of a component's JSON form as every surface shows it: gain
    spreads (relative variances) as % rms with the SE propagated; a variance (or gain
    spread) is a figure whose truth may be 0, so one estimated below 0 within 3 SE of it,
    or one whose SE exceeds it, is an upper limit (value + 3 SE), one further below 0 "the
    model does not fit" (as ``stats.physical.in_range`` and ``resolved`` judge them); a
    limit already judged is shown as one; the rest as value ± SE with the SE's digits
    (``format_value``)."""
    v, se = d.get("value"), d.get("se")
    finite_se = se is not None and math.isfinite(se)
    if v is None or not math.isfinite(v):
        return "n/a" + (f" ({d['note']})" if d.get("note") else ""), d.get("unit", "")
    unit = d.get("unit", "")
    spread = c in GAIN_SPREADS
    limit = {VERDICT_UPPER: "<", VERDICT_LOWER: ">"}.get(d.get("verdict", ""))
    if spread or unit.endswith("^2"):
        show_unit = "% rms" if spread else unit

        def lim(x: float, sign: str = "<") -> str:
            return f"{sign} {100 * math.sqrt(max(x, 0.0)):.2g}" if spread else f"{sign} {format_value(x, sig=2)}"

        if limit:  # only a limit is known: never shown as a plain value
            return lim(v, limit), show_unit
        if v < 0:
            if finite_se and v + LIMIT_NSIGMA * se >= 0:
                return f"{lim(v + LIMIT_NSIGMA * se)} (est. {v:.2g}, below 0)", show_unit
            what = "a gain spread's relative variance" if spread else "negative variance"
            return f"n/a ({what} {v:.3g} ± {se:.2g} {unit}: the model does not fit)".replace(" 1:", ":"), show_unit
        if finite_se and se > v:
            return f"{lim(v + LIMIT_NSIGMA * se)} (est. {v:.2g}, not resolved from 0)", show_unit
        if spread:
            return format_value(pct_rms(v), 100 * se / (2 * math.sqrt(v)) if finite_se and v > 0 else None), show_unit
    elif limit:
        return f"{limit} {format_value(v)}", unit
    if se is not None and se == 0:  # exact (a gain given, not measured): its verdict, no invented SE
        return f"{format_value(v, None, EXACT_DIGITS)} ({exact_text(d.get('exact', ''))})", unit
    return format_value(v, se), unit


def component_text(c: str, d: dict) -> str:
    """``component_display`` as one string, the unit after the number."""
    text, unit = component_display(c, d)
    if text.startswith("n/a") or not unit:
        return text
    if (text.startswith(("<", ">")) or "(exact: " in text) and " (" in text:  # "< 0.23 (est. ...)" -> "< 0.23 % rms (est. ...)"
        head, _, tail = text.partition(" (")
        return f"{head} {unit} ({tail}"
    return f"{text} {unit}"
