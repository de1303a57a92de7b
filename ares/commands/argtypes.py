"""argparse types for the physical quantities options take: a bad value is argparse's one
sentence naming the option, exit 2 -- never a number the analysis then divides by."""

from __future__ import annotations

import argparse
import math


def positive(text: str) -> float:
    """A finite number > 0 (a gain, a wavelength, a pixel pitch, an LSB)."""
    x = _number(text)
    if not x > 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got '{text}'")
    return x


def gain(text: str) -> float:
    """A system gain in DN/e-: > 0 and at most 1e6 (no sensor gives more a electron; a
    larger value is a unit slip, e-/DN for DN/e- or uV for V)."""
    x = positive(text)
    if x > 1e6:
        raise argparse.ArgumentTypeError(f"a gain of {x:g} DN/e- is beyond any sensor's (at most 1e6), got '{text}'")
    return x


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
