"""ARES analysis engine: pure numpy/scipy, no Qt, no file I/O; imports nothing of ARES but
``ares.errors`` and its own rooms.

Rooms by concern, each a package; a room imports only the rooms before it in this list:

* ``kernels/`` numba kernels and their compile helpers (``jit``);
* ``stats/``   a value with its SE and verdict, physical ranges, small fits, splines, medians, tails;
* ``spatial/`` the EMVA 1288 high-/low-pass and the row/column/pixel split of spatial variances;
* ``noise/``   accumulators, the 13-component decomposition, regions, panels;
* ``ptc/``     photon transfer, gain fits, saturation/turnoff, read noise, dark current, lag, ADC;
* ``emva/``    each EMVA 1288 release, its sheet and graphs;
* ``optics/``  MTF, photon counting, spectral QE;
* ``defects/`` defect identification and classes.

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

# Names are imported on first use (PEP 562): ``import ares.analysis.stats.estimate`` -- as the CLI
# does for ``ares --help`` -- must not pull in scipy.signal through the decomposition.
_HOME = {
    "StackAccumulator": "noise.accumulate", "MaskedStackAccumulator": "noise.masked", "masked_components": "noise.masked",
    "DARK_NAMES": "noise.anova", "AnovaTable": "noise.anova", "anova_table": "noise.anova", "decompose_dark": "noise.anova",
    "in_electrons": "noise.anova", "sigma_view": "noise.anova", "COMPONENT_NAMES": "noise.decompose", "UNITS_NOTE": "noise.decompose",
    "StackAnalysis": "noise.decompose", "Estimate": "stats.estimate", "GAIN_NAMES": "noise.flat", "decompose_flat": "noise.flat",
    "highpass_emva": "noise.flat", "Panel": "noise.panels", "pixel_gain_map": "noise.panels", "result_panels": "noise.panels",
    "robust_gauss_fit": "noise.panels", "summarize": "noise.panels", "value_range": "noise.panels",
    **{n: "noise.regions" for n in ("Region", "Selection", "SelectionSet", "adc_channels", "bayer_channels", "full_frame",
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
