"""The scan-level ``mtf`` analysis: the slanted-edge MTF (ISO 12233 e-SFR,
``ares.analysis.optics.mtf``) of each flat stage's dark-subtracted mean image, per Bayer channel
when the system's sensor declares a CFA; with ``<analysis name="mtf" esf_half_width="16"/>``
the option's result beside the standard's (``option`` in each channel). Registered by importing ``ares.results``."""

from __future__ import annotations

import numpy as np

from ares.analysis.optics.mtf import CHANNEL_NAMES, channels_dict, sfr_channels
from ares.results.registry import register_scan_analysis


@register_scan_analysis("mtf")
def mtf(run) -> dict:
    sensor = run.system.sensor
    cfa = sensor.cfa if (sensor.cfa or "").upper() in CHANNEL_NAMES else None
    full = float(2 ** sensor.adc_bits - 1)
    out = {}
    for st in run.stages:
        if st["scene"] != "flat":
            continue
        arr = run.arrays(st["index"])
        if "mean" not in arr:
            continue
        mean = np.asarray(arr["mean"], np.float64)
        # clipping is judged on the raw mean (a pixel at full scale in every frame); the
        # SFR is taken of the dark-subtracted mean
        clipped = int(np.sum(mean >= full - 0.5))
        img = mean - np.asarray(arr["dark_mean"], np.float64) if "dark_mean" in arr else mean
        res = sfr_channels(img, cfa)
        hw = run.scan.option("mtf", "esf_half_width") if getattr(run, "scan", None) is not None else None
        opt = sfr_channels(img, cfa, esf_half_width=hw) if hw is not None and not clipped else None
        chans = channels_dict(res, opt, hw)
        if clipped:
            why = (f"clipping: {clipped} pixels are at the full-scale code {full:g} in every frame; "
                   "lower the exposure or the light")
            chans = {k: {"angle_deg": d["angle_deg"], "mtf50_cy_per_px": {"value": None, "se": None, "unit": "cy/px",
                                                                          "verdict": "not available", "note": why},
                         "mtf_at_nyquist": {"value": None, "se": None, "unit": "", "verdict": "not available",
                                            "note": why}, "nyquist_cy_per_px": d["nyquist_cy_per_px"]}
                     for k, d in chans.items()}
        out[st["name"]] = {"frames": st["frames"], "dark_subtracted": "dark_mean" in arr, "channels": chans}
    if not out:
        return {"status": "not available", "note": "no flat stage with a mean image (an edge target) in the run"}
    return {"stages": out}
