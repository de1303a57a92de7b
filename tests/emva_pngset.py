"""A small EMVA 1288 data set written as PNGs with a descriptor (method I: exposure varied),
to feed ``ares emva`` inputs a real set would rarely have: declared photons below the
charge collected (a QE above 1, hence an SNR_max above sqrt of the photons), a dark level
that falls with exposure (a negative dark current), an 8-bit camera whose dark noise is
below the quantization floor. 32 x 32 pixels, 2 frames per step: writes in well under 1 s."""

from __future__ import annotations

import numpy as np
from PIL import Image


def write_set(path, *, qe=0.6, photons_scale=1.0, K=0.3, read_e=6.0, full_well_e=1e9, bits=12,
              offset=100.0, dark_slope_dn_per_s=0.0, dark_sigma_dn=None, steps=24, shape=(32, 32), seed=0):
    # (dark_slope_dn_per_s: the dark level's drift with exposure, no shot noise: < 0 imitates a
    # falling offset, which reads as a negative dark current)
    """The descriptor's path. ``photons_scale``: declared photons / true photons;
    ``dark_sigma_dn``: dark noise in DN (default from ``read_e``)."""
    rng = np.random.default_rng(seed)
    top = 2**bits - 1
    flux = 1e6  # photons / pixel / s
    t_sat = min(full_well_e, (top - offset) / K) / qe / flux  # the ADC clips first by default
    times = np.r_[np.linspace(0.02, 1.0, steps - 4), 1.05, 1.12, 1.2, 1.3] * t_sat
    img = path / "images"
    img.mkdir(parents=True, exist_ok=True)
    sig_d = K * read_e if dark_sigma_dn is None else dark_sigma_dn
    lines = ["# synthetic set (tests/emva_pngset.py)", "v 4.0", f"n {bits} {shape[1]} {shape[0]}"]

    def frame(t, lit):
        q = rng.poisson(qe * flux * t, shape) if lit else np.zeros(shape)
        y = offset + dark_slope_dn_per_s * t + K * np.minimum(q, full_well_e) + rng.normal(0, sig_d, shape)
        return np.clip(np.round(y), 0, top).astype(np.uint8 if bits <= 8 else np.uint16)

    for kind in ("b", "d"):
        for k, t in enumerate(times):
            t_ns = t * 1e9
            lines.append(f"b {t_ns:.6g} {photons_scale * flux * t:.6g}" if kind == "b" else f"d {t_ns:.6g}")
            for j in range(2):
                name = f"{kind}_{k:03d}_{j}.png"
                Image.fromarray(frame(t, kind == "b")).save(img / name)
                lines.append(f"i images\\{name}")
    p = path / "data.txt"
    p.write_text("\n".join(lines) + "\n")
    return p
