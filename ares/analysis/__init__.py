"""ARES analysis engine: pure numpy/scipy, no Qt, no file I/O.

Public API (noise decomposition part):

* ``StackAccumulator(shape)`` -- one-pass, mergeable frame-stack sums;
* ``decompose_dark(acc)`` -- unbiased three-way ANOVA dark components (DN, DN^2);
* ``anova_table``, ``sigma_view``, ``in_electrons``.
"""

from .accumulate import StackAccumulator
from .anova import DARK_NAMES, AnovaTable, anova_table, decompose_dark, in_electrons, sigma_view
from .estimate import Estimate

__all__ = [
    "Estimate",
    "StackAccumulator",
    "DARK_NAMES",
    "AnovaTable",
    "anova_table",
    "decompose_dark",
    "in_electrons",
    "sigma_view",
]
