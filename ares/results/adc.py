"""The scan-level ``adc_linearity`` analysis: INL/DNL per ADC channel by the code-density test
(``ares.analysis.ptc.adc``) on the ramp stages' (test_mode 2) code histograms in results.h5, and
``ramp_curves``, the same curves for the reports (CSV, HDF5, PDF). A ramp stage keeps its
histogram as sub-histograms too (``histgroups_<view>``, frame i in group i mod 16): every SE
comes from their scatter. A run directory written before them (``hist_<view>`` only) gets the
counting SE, and its notes say so. Registered by importing ``ares.results``."""

from __future__ import annotations

import numpy as np

from ares.results.registry import register_scan_analysis


def ramp_stages(run) -> list[dict]:
    return [s for s in run.stages if s["settings"].get("reg:test_mode") == 2]


def ramp_curves(run, stages=None) -> dict:
    """Channel -> ``InlDnl`` of the ramp stages (names ``stages``, default every test_mode 2
    stage): their summed histograms, and their sub-histograms stacked when every stage kept
    them. The channels are the ADC views (``adc0``...) when the run has them, else ``full``;
    a channel whose histogram covers fewer than 3 codes is left out."""
    from ares.analysis.ptc.adc import from_histogram

    sts = [s for s in run.stages if s["name"] in stages] if stages is not None else ramp_stages(run)
    hists: dict = {}
    groups: dict = {}
    for st in sts:
        arr = run.arrays(st["index"])
        for k, a in arr.items():
            if k.startswith("hist_"):
                ch = k[5:]
                hists[ch] = hists.get(ch, 0) + np.asarray(a, np.int64)
                g = arr.get(f"histgroups_{ch}")
                groups.setdefault(ch, []).append(None if g is None else np.asarray(g, np.int64))
    out = {}
    for ch in [k for k in hists if k.startswith("adc")] or [k for k in hists if k == "full"]:
        g = groups.get(ch) or [None]
        try:
            out[ch] = from_histogram(hists[ch], groups=None if any(x is None for x in g) else np.concatenate(g))
        except ValueError:
            pass
    return out


@register_scan_analysis("adc_linearity")
def adc_linearity(run) -> dict:
    """INL/DNL extremes per ADC channel, each with its SE (``InlDnl.extremes``)."""
    ramps = ramp_stages(run)
    if not ramps:
        return {"status": "not available", "note": "needs a ramp stage (test_mode 2)"}
    curves = ramp_curves(run)
    if not curves:
        return {"status": "not available", "note": "needs the run directory's results.h5 (code histograms)"}
    out = {"stages": [s["name"] for s in ramps], "channels": {}}
    for ch, r in curves.items():
        ext = r.extremes()
        out["channels"][ch] = {
            **{f"{k}_lsb": e.to_dict() for k, e in ext.items()},
            "missing_codes": int(r.missing_codes.size), "codes": [r.first, r.last], "samples": r.samples,
            "samples_per_code": round(r.per_code, 1), "sub_histograms": r.groups}
    return out
