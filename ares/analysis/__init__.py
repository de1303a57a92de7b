"""ARES analysis engine: pure numpy/scipy, no Qt, no file I/O.

Noise decomposition API:

* ``StackAccumulator(shape)`` -- one-pass, exact, mergeable frame-stack sums
  (``add``, ``add_batch``, ``merge``, ``mean_map``, ``temporal_var_map`` ...);
* ``decompose_dark(acc)`` -- unbiased three-way ANOVA dark components
  (o, Cs, Ct, Rs, Rt, Ps, Pt, frame_global; DN and DN^2) with standard errors;
* ``decompose_flat(flat_acc, dark_acc, gain=None, illumination="highpass")`` -- G, Cg,
  Rg, Pg, q, delta (+ signal, poisson_ratio);
* ``MaskedStackAccumulator(shape, mask)`` -- the same sums over the good pixels of a
  fixed defect mask; ``decompose_dark``/``decompose_flat``/``StackAnalysis`` then use the
  unbalanced (Henderson method I) ANOVA of ``masked.py``; ``masked_components(dark, mask,
  flat=None)`` for recorded stacks;
* ``StackAnalysis(dark_acc, flat_acc=None, gain=None)`` -- lazy, cached façade,
  ``components()`` keyed by the model's names;
* regions (``Region``, ``Selection``, ``SelectionSet``, ``bayer_channels``,
  ``adc_channels``, ``ob_columns``) and result panels (``result_panels``, ``Panel``,
  ``robust_gauss_fit``, ``pixel_gain_map``).
"""

from .accumulate import StackAccumulator
from .anova import DARK_NAMES, AnovaTable, anova_table, decompose_dark, in_electrons, sigma_view
from .decompose import COMPONENT_NAMES, UNITS_NOTE, StackAnalysis
from .estimate import Estimate
from .flat import GAIN_NAMES, decompose_flat, highpass_emva
from .masked import MaskedStackAccumulator, masked_components
from .panels import Panel, pixel_gain_map, result_panels, robust_gauss_fit, summarize, value_range
from .regions import (
    Region,
    Selection,
    SelectionSet,
    adc_channels,
    bayer_channels,
    full_frame,
    ob_columns,
    parse_roi,
    region_selection,
)

__all__ = [
    "Estimate",
    "StackAccumulator",
    "MaskedStackAccumulator",
    "masked_components",
    "DARK_NAMES",
    "GAIN_NAMES",
    "COMPONENT_NAMES",
    "UNITS_NOTE",
    "AnovaTable",
    "anova_table",
    "decompose_dark",
    "decompose_flat",
    "highpass_emva",
    "in_electrons",
    "sigma_view",
    "StackAnalysis",
    "Region",
    "Selection",
    "SelectionSet",
    "adc_channels",
    "bayer_channels",
    "full_frame",
    "ob_columns",
    "parse_roi",
    "region_selection",
    "Panel",
    "pixel_gain_map",
    "result_panels",
    "robust_gauss_fit",
    "summarize",
    "value_range",
]
