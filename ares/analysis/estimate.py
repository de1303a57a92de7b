"""A value with its standard error and unit -- the currency of every result.

``Estimate.na(reason)`` marks a quantity that cannot be estimated from the data (one
frame, dark-only, one row ...): it is reported as *not available*, never as 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Estimate:
    value: float
    se: float = math.nan
    unit: str = ""
    note: str = ""

    @classmethod
    def na(cls, reason: str, unit: str = "") -> "Estimate":
        return cls(math.nan, math.nan, unit, reason)

    @property
    def available(self) -> bool:
        return math.isfinite(self.value)

    def to_dict(self) -> dict:
        d = {
            "value": self.value if self.available else None,
            "se": self.se if math.isfinite(self.se) else None,
            "unit": self.unit,
        }
        if self.note:
            d["note"] = self.note
        return d

    def __format__(self, spec: str) -> str:
        if not self.available:
            return "n/a"
        spec = spec or ".4g"
        s = format(self.value, spec)
        if math.isfinite(self.se):
            s += " ± " + format(self.se, spec)
        return s
