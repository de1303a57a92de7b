"""Lazy façade over the noise decomposition of one region/channel.

``StackAnalysis(dark_acc, flat_acc=None, gain=None)`` computes nothing up front; each
result is computed on first request and cached: asking for a signal map does not run the
ANOVA, and a dark-only analysis never tries the gain components.
``components()`` returns the 13 model components plus the frame-global term, keyed
``o, Cs, Ct, Rs, Rt, Ps, Pt, frame_global, G, Cg, Rg, Pg, q, delta`` (DN, DN^2, DN/e-,
relative-gain variances, e-, e-^2).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from ares.analysis.noise.accumulate import StackAccumulator
from ares.analysis.noise.anova import DARK_NAMES, AnovaTable, anova_table, decompose_dark, in_electrons, sigma_view
from ares.analysis.stats.estimate import Estimate
from ares.analysis.noise.flat import GAIN_NAMES, decompose_flat, gain_na
from ares.analysis.stats.physical import variances_in_range

__all__ = ["StackAnalysis", "COMPONENT_NAMES", "UNITS_NOTE"]

COMPONENT_NAMES = DARK_NAMES + GAIN_NAMES
UNITS_NOTE = (
    "o in DN; Cs, Ct, Rs, Rt, Ps, Pt, frame_global are variances in DN^2; G in DN/e-; "
    "Cg, Rg, Pg are variances of the relative gains (dimensionless); q in e-; delta in e-^2"
)


class StackAnalysis:
    """Lazily computed, cached results for a dark stack and an optional flat stack."""

    def __init__(
        self,
        dark_acc: StackAccumulator,
        flat_acc: StackAccumulator | None = None,
        gain: float | None = None,
        illumination: str = "highpass",
        surface_order: int = 2,
    ):
        self.dark = dark_acc
        self.flat = flat_acc
        self.gain = gain
        self.illumination = illumination
        self.surface_order = surface_order
        self.computed: list[str] = []  # names of the results computed so far (for tests/GUI)

    def _mark(self, name: str) -> None:
        self.computed.append(name)

    # ---- maps (no ANOVA)
    @cached_property
    def signal_map(self) -> np.ndarray:
        """Mean photo-signal map (flat - dark) with a flat, else the dark mean map (DN)."""
        self._mark("signal_map")
        if self.flat is not None:
            return self.flat.mean_map() - self.dark.mean_map()
        return self.dark.mean_map()

    @cached_property
    def noise_map(self) -> np.ndarray:
        """Per-pixel temporal sigma (ddof=1) of the flat stack if given, else of the dark (DN)."""
        self._mark("noise_map")
        acc = self.flat if self.flat is not None else self.dark
        return np.sqrt(acc.temporal_var_map())

    # ---- ANOVA
    @cached_property
    def dark_table(self) -> AnovaTable:
        self._mark("dark_table")
        return anova_table(self.dark)

    @cached_property
    def flat_table(self) -> AnovaTable | None:
        if self.flat is None:
            return None
        self._mark("flat_table")
        return anova_table(self.flat)

    @cached_property
    def dark_components(self) -> dict[str, Estimate]:
        return decompose_dark(self.dark, self.dark_table)

    @cached_property
    def flat_stack_components(self) -> dict[str, Estimate] | None:
        """The dark-model ANOVA of the flat stack itself (e.g. light-source flicker in frame_global)."""
        if self.flat is None:
            return None
        return decompose_dark(self.flat, self.flat_table)

    @cached_property
    def gain_components(self) -> dict[str, Estimate]:
        if self.flat is None:
            return gain_na()
        self._mark("gain")
        return decompose_flat(
            self.flat, self.dark, gain=self.gain, illumination=self.illumination,
            surface_order=self.surface_order, flat_table=self.flat_table, dark_table=self.dark_table,
        )

    def components(self) -> dict[str, Estimate]:
        """All components keyed by the model's names (see module docstring), as shown: a
        variance below zero is an upper limit or not available (``ares.analysis.stats.physical``;
        ``dark_components`` keeps the unbiased raw estimates for averaging)."""
        d = variances_in_range(dict(self.dark_components))
        g = self.gain_components
        d.update({k: g[k] for k in GAIN_NAMES})
        return d

    def extras(self) -> dict[str, Estimate]:
        """signal (DN) and, with a given gain, poisson_ratio."""
        g = self.gain_components
        return {k: v for k, v in g.items() if k not in GAIN_NAMES}

    def sigmas(self) -> dict[str, Estimate]:
        """Clipped square roots of the variance components (DN)."""
        return sigma_view(self.dark_components)

    def in_electrons(self) -> dict[str, Estimate]:
        """Dark components in e- / e-^2 using the given or estimated gain."""
        g = self.gain if self.gain is not None else self.gain_components["G"].value
        if g is None or not np.isfinite(g):
            return {k: Estimate.na("no conversion gain", "e-") for k in DARK_NAMES}
        return in_electrons(variances_in_range(dict(self.dark_components)), g)  # (as shown: a limit stays one)
