"""The photon-counting validation corpus (issue 48 (d)): low-light and dark stacks from the
shipped simulator (no fixed-pattern noise, exact Poisson photo-charge) over K 2-30 DN/e-,
read noise 0.1-0.5 e-, 0.05-2 e-/pixel, with the truth; used by tests/test_photon_counting_corpus.py
and benchmarks/bench_photon_counting.py."""

from __future__ import annotations

import numpy as np

from ares.analysis.optics.photon_counting import fit_histogram, result_dict
from ares.sim.params import SensorParams
from ares.sim.sensor import SimSensor

GAINS = (2.0, 5.0, 10.0, 20.0, 30.0)
READ_NOISES = (0.1, 0.15, 0.3, 0.45, 0.5)
CHARGES = (0.05, 0.1, 0.5, 2.0)
LSB_UV = 7.0
QE = 0.6
EXPOSURE = 0.01


def case(K, rn, H, seed, frames=20, size=64, dark=True):
    """``(truth, light, dark)``: truth ``{"K", "read_noise_e", "mean_e"}``."""
    p = SensorParams(rows=size, cols=size, conversion_gain_uv_per_e=K * LSB_UV, adc_lsb_uv=LSB_UV,
                     adc_bits=16, qe=QE).noiseless().replace(read_noise_e=rn)
    s = SimSensor(p, seed=seed)
    flux = H / (EXPOSURE * QE)
    light = s.render(frames, exposure_s=EXPOSURE, photon_flux=flux, black_level_dn=100, shot_noise="exact")
    # exact Gaussian read noise in the dark too: the fast table cuts the tails at 4.3 sigma, which
    # a histogram of millions of values shows (scatter 2.8x its Poisson expectation at 3 M values)
    d = s.render(frames, exposure_s=EXPOSURE, dark=True, black_level_dn=100, shot_noise="exact") if dark else None
    t = s.truth(exposure_s=EXPOSURE, photon_flux=flux, black_level_dn=100)
    return {"K": t["G"], "read_noise_e": t["read_noise_e"], "mean_e": float(np.mean(t["maps"]["q"]))}, light, d


def run_case(K, rn, H, seed, **kw) -> dict:
    """One fit against its truth: relative errors and relative SEs of K and read noise."""
    t, light, dark = case(K, rn, H, seed, **kw)
    r = fit_histogram(light, dark=dark)
    d = result_dict(r)
    out = {"K": K, "rn": rn, "H": H, "seed": seed, "available": r["K"].available, "note": r["K"].note,
           "frames": light.shape[0], "size": light.shape[1], "k_verdict": d["K"]["verdict"],
           "k_needs_values": d["K"].get("needs_values"), "rn_verdict": d["read_noise_e"]["verdict"],
           "values": int(light.size + (dark.size if dark is not None else 0))}
    if r["K"].available:
        out.update(k_err=r["K"].value / t["K"] - 1, k_se=r["K"].se / t["K"])
        e = r["read_noise_e"]
        out.update(rn_err=e.value / t["read_noise_e"] - 1 if not e.bound else float("nan"),
                   rn_se=e.se / t["read_noise_e"] if not e.bound else float("nan"), rn_bound=e.bound)
    return out
