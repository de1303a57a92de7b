"""argparse types for the physical quantities options take: a bad value is argparse's one
sentence naming the option, exit 2 -- never a number the analysis then divides by."""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

from ares.errors import InputError


def positive(text: str) -> float:
    """A finite number > 0 (a gain, a wavelength, a pixel pitch, an LSB)."""
    x = _number(text)
    if not x > 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got '{text}'")
    return x


# A bare number is taken in DN/e- only inside the range sensors give (photon-counting
# sensors reach ~20 DN/e-, deep-well CCDs ~0.01): outside it the number is far likelier a
# conversion gain in uV/e- (typ. 2-200) or an inverse gain in e-/DN, and is refused with a hint.
BARE_GAIN_RANGE = (1e-3, 50.0)
_GAIN_UNITS = {"dn/e-": "DN/e-", "dn/e": "DN/e-", "adu/e-": "DN/e-", "adu/e": "DN/e-",
               "e-/dn": "e-/DN", "e/dn": "e-/DN", "e-/adu": "e-/DN", "e/adu": "e-/DN",
               "uv/e-": "uV/e-", "uv/e": "uV/e-", "µv/e-": "uV/e-", "µv/e": "uV/e-"}


@dataclass(frozen=True)
class GainArg:
    """A gain as typed: ``value`` in ``unit`` (DN/e-, e-/DN or uV/e-); ``dn_per_e(lsb_uv)``
    gives the system gain the analysis takes."""

    value: float
    unit: str
    text: str

    def dn_per_e(self, lsb_uv: float | None, option: str = "--gain") -> float:
        if self.unit == "DN/e-":
            return self.value
        if self.unit == "e-/DN":
            return 1.0 / self.value
        if lsb_uv is None:
            raise InputError(f"{option} {self.text}: a conversion gain in uV/e- needs the ADC step "
                             "(--adc-lsb-uv, the voltage of one DN in uV) to become DN/e-")
        return self.value / lsb_uv


def gain(text: str) -> GainArg:
    """A gain with its unit: ``0.28`` or ``0.28DN/e-`` (system gain), ``3.57e-/DN`` (inverse
    gain), ``70uV/e-`` (conversion gain: the command needs ``--adc-lsb-uv`` too). A bare number
    outside ``BARE_GAIN_RANGE`` is refused with a hint (it is likely another unit); with an
    explicit DN/e- any value up to 1e6 is taken (no sensor gives more a electron)."""
    t = text.strip()
    num = t.rstrip("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZµ/- ")
    tail = t[len(num):].strip()
    if not num or tail.lower() in ("nan", "inf", "infinity"):  # no digits: let the number say why
        num, tail = t, ""
    unit = _GAIN_UNITS.get(tail.lower().replace(" ", "")) if tail else "DN/e-"
    if unit is None:
        raise argparse.ArgumentTypeError(f"'{text}': unknown gain unit '{tail}' (use DN/e-, e-/DN or uV/e-)")
    x = positive(num)
    if unit == "DN/e-" and x > 1e6:
        raise argparse.ArgumentTypeError(f"a gain of {x:g} DN/e- is beyond any sensor's (at most 1e6), got '{text}'")
    if not tail and not BARE_GAIN_RANGE[0] <= x <= BARE_GAIN_RANGE[1]:
        lo, hi = BARE_GAIN_RANGE
        hint = (f"a conversion gain is written {x:g}uV/e- (with --adc-lsb-uv), an inverse gain {x:g}e-/DN" if x > hi
                else f"a conversion gain in V/e- is written {x * 1e6:g}uV/e- (with --adc-lsb-uv)")
        raise argparse.ArgumentTypeError(
            f"a bare gain of {x:g} is outside {lo:g}-{hi:g} DN/e- (sensors' range): {hint}, "
            f"or {x:g}DN/e- to insist")
    return GainArg(x, unit, t)


def non_negative(text: str) -> float:
    """A finite number >= 0 (an exposure time)."""
    x = _number(text)
    if not x >= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got '{text}'")
    return x


def _number(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"must be a finite number, got '{text}'")
    return x
