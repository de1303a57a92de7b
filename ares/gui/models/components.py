"""Noise Components table model: the engine's decomposition of the latest stage (no Qt).

The runner reports, per view (full frame, each scan region, CFA phase, ADC channel),
the 13-component model's estimates with standard errors (``Estimate.to_dict()``). The
model only picks a view and orders the rows; it computes nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ares import labels
from ares.analysis.stats.estimate import component_display

from ares.gui.models.observable import Observable

# (symbol, meaning) in the order of DESIGN.md's model; others follow as reported
DESCRIPTIONS = labels.COMPONENTS


@dataclass(frozen=True)
class ComponentRow:
    symbol: str
    description: str
    value: float
    se: float
    unit: str
    note: str = ""
    verdict: str = ""  # (a limit is shown as one: "< x")

    @property
    def text(self) -> str:
        """The value as the CLI and the PDF show it (gain spreads in % rms, the SE's digits)."""
        return self._shown()[0]

    @property
    def shown_unit(self) -> str:
        return self._shown()[1]

    def _shown(self) -> tuple[str, str]:
        d = {"value": self.value if math.isfinite(self.value) else None,
             "se": self.se if math.isfinite(self.se) else None, "unit": self.unit, "note": self.note,
             "verdict": self.verdict}
        return component_display(self.symbol, d)


def _num(v) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan


class ComponentsModel(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.views: dict[str, dict] = {}  # view -> {"components": {...}, "dark_components": {...}}
        self.view = "full"
        self.caption = ""

    def set_stage(self, caption: str, views: dict[str, dict]) -> None:
        self.views = dict(views)
        self.caption = caption
        self._changed()

    def clear(self) -> None:
        self.views, self.caption = {}, ""
        self._changed()

    def select(self, view: str) -> None:
        if view != self.view:
            self.view = view
            self._changed()

    def masked_pixels(self) -> int:
        """Defect pixels left out of the view's components (0: none, or no mask)."""
        v = self.views.get(self.view) or {}
        return int(v.get("masked_pixels") or 0) if v.get("components_masked") else 0

    def rows(self, which: str = "components") -> list[ComponentRow]:
        """The view's components as the terminal and the report state them: with a defect
        mask, the decomposition without the defect pixels (``components_masked``)."""
        v = self.views.get(self.view) or {}
        comps = (v.get("components_masked") if which == "components" and v.get("components_masked")
                 else v.get(which)) or {}
        order = [k for k in DESCRIPTIONS if k in comps] + [k for k in comps if k not in DESCRIPTIONS]
        out = []
        for k in order:
            d = comps[k] if isinstance(comps[k], dict) else {"value": comps[k]}
            out.append(ComponentRow(k, DESCRIPTIONS.get(k, ""), _num(d.get("value")), _num(d.get("se")),
                                    str(d.get("unit", "")), str(d.get("note", "")), str(d.get("verdict", ""))))
        return out
