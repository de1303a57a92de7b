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

# Names are imported on first use (PEP 562): ``import ares.analysis.estimate`` -- as the CLI
# does for ``ares --help`` -- must not pull in scipy.signal through the decomposition.
_HOME = {
    "StackAccumulator": "accumulate", "MaskedStackAccumulator": "masked", "masked_components": "masked",
    "DARK_NAMES": "anova", "AnovaTable": "anova", "anova_table": "anova", "decompose_dark": "anova",
    "in_electrons": "anova", "sigma_view": "anova", "COMPONENT_NAMES": "decompose", "UNITS_NOTE": "decompose",
    "StackAnalysis": "decompose", "Estimate": "estimate", "GAIN_NAMES": "flat", "decompose_flat": "flat",
    "highpass_emva": "flat", "Panel": "panels", "pixel_gain_map": "panels", "result_panels": "panels",
    "robust_gauss_fit": "panels", "summarize": "panels", "value_range": "panels",
    **{n: "regions" for n in ("Region", "Selection", "SelectionSet", "adc_channels", "bayer_channels", "full_frame",
                              "ob_columns", "parse_roi", "region_selection")},
}


def __getattr__(name: str):
    mod = _HOME.get(name)
    if mod is None:
        raise AttributeError(f"module 'ares.analysis' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f".{mod}", __name__), name)
    globals()[name] = value
    return value


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
