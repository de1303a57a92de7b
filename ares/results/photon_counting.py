"""The scan-level ``photon_counting`` analysis: the photon-counting histogram fit
(``ares.analysis.optics.photon_counting``, Starkey & Fossum 2016) of each flat stage's code
histogram (the run keeps it when the scan lists this analysis), beside the photon-transfer
estimate of the same stage's light and matched-dark temporal variances. Registered by
importing this module (ares.results.analyses)."""

from __future__ import annotations

import numpy as np

from ares.results.registry import register_scan_analysis


@register_scan_analysis("photon_counting")
def photon_counting(run) -> dict:
    from ares.analysis.optics.photon_counting import fit_code_histogram, photon_transfer_levels, result_dict

    out = {}
    for st in run.stages:
        if st["scene"] != "flat":
            continue
        h = run.arrays(st["index"]).get("hist_full")
        if h is None:
            continue
        h = np.asarray(h, np.float64)
        r = fit_code_histogram(np.arange(h.size), h)
        pt = None
        full = st["views"]["full"]
        if "dark_level" in full:
            lv, dk = full["level"], full["dark_level"]
            pt = photon_transfer_levels(lv["mean_dn"], lv["var_dn2"], lv["n_frames"], dk["mean_dn"], dk["var_dn2"],
                                        dk["n_frames"], lv["n_pixels"])
        out[st["name"]] = result_dict(r, pt)
    if not out:
        return {"status": "not available", "note": "no flat stage with a code histogram in the run"}
    return {"stages": out}
