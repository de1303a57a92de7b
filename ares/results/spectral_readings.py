"""What a spectral bench's instruments say beside each stack (EMVA 1288 4.0 Linear,
Section 9): the monochromator's wavelength read back and its bandwidth, and the reference
photodiode's readings (``<photodiode samples>`` of them), recorded in the stage result
(``spectral``) for ``ares.results.spectral_qe``. Nothing on a bench without them."""

from __future__ import annotations

import math


def photodiode_readings(bench, system) -> list[float] | None:
    pd = getattr(bench, "photodiode", None)
    if pd is None or system.photodiode is None:
        return None
    return [float(pd.read()) for _ in range(system.photodiode.samples)]


def spectral_readings(bench, system) -> dict | None:
    """``{"wavelength_nm", "bandwidth_nm", "pd_unit", "pd_light"}`` after a lit stack, or None."""
    mono = getattr(bench, "monochromator", None)
    light = photodiode_readings(bench, system)
    if mono is None and light is None:
        return None
    bw = mono.bandwidth() if mono is not None else math.nan
    return {"wavelength_nm": float(mono.get_wavelength()) if mono is not None else None,
            "bandwidth_nm": bw if math.isfinite(bw) else None,
            "pd_unit": None if system.photodiode is None else ("A" if system.photodiode.reading == "current" else "W"),
            "pd_light": light}
