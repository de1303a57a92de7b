"""A precision-driven photon-transfer scan over many seeds on the simulator, next to the
fixed-frame scan tuned with hindsight (used by tests/test_precision.py and
benchmarks/bench_precision.py).

The sensor is the shipped one cut to 64x64 without defect pixels, image lag or ADC INL,
so the truth is exact: the realized mean gain of the pixels, and the dark temporal noise
the read-noise estimate measures.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ares.sim.from_system import sim_params
from ares.protocol import load_scan
from ares.protocol.scan import Precision, Target
from ares.scan import Runner
from ares.scan.precision import PrecisionRunner
from ares.results.registry import find_estimate
from ares.sim import make_sim_bench

ROOT = Path(__file__).resolve().parents[1]
TARGETS = (Target("gain_dn_per_e", rel=0.003), Target("read_noise_e", rel=0.015))


def study_scan(size: int = 64, budget: int = 64, pilot: int = 3):
    s = load_scan(ROOT / "scans" / "photon_transfer.xml")
    sy = s.system
    params = dict(sy.simulator.params, rows=size, cols=size, lag_fraction=0.0, adc_inl_lsb=0.0)
    sy = dataclasses.replace(sy, sensor=dataclasses.replace(sy.sensor, rows=size, cols=size),
                             simulator=dataclasses.replace(sy.simulator, params=params))
    return dataclasses.replace(s, system=sy, regions=(), analyses=("ptc",), limits=(),
                               precision=Precision(TARGETS, budget, pilot))


def _bench(scan, seed):
    return make_sim_bench(sim_params(scan.system).without_defects(), seed)


def _truth_gain(bench) -> float:
    return float(bench.info["sensor"].truth()["maps"]["gain_dn_per_e"].mean())


def _met(results) -> bool:
    return all((e := find_estimate(results, t.quantity)) is not None and e.get("se") is not None
               and e["se"] <= t.wanted(e["value"]) for t in TARGETS)


def run_study(seeds: int = 100, size: int = 64) -> dict:
    """Per seed: the precision-driven run (frames used, targets met, gain error) and the
    fixed-frame run at the hindsight frame count (same seed)."""
    scan = study_scan(size)
    prec = []
    for seed in range(seeds):
        b = _bench(scan, seed)
        pr = PrecisionRunner(scan, bench=b, seed=seed)
        out = pr.run()
        g = find_estimate(out.scan_results, "gain_dn_per_e")
        worst = max(t["se"] / t_.wanted(t["value"]) for t, t_ in zip(pr.report["targets"], TARGETS))
        prec.append((pr.report["frames_per_stage"], pr.report["all_met"], g["value"] - _truth_gain(b), g["se"], worst))
    n = np.array([p[0] for p in prec])
    worst = np.array([p[4] for p in prec])
    # hindsight: the smallest fixed count at which 95 % of these seeds' SEs (scaled by the
    # 1/sqrt(n - 1) law from the frames each run used) meet every target
    n_fixed = next(k for k in range(2, 1000) if np.mean(worst * np.sqrt((n - 1) / (k - 1)) <= 1) >= 0.95)
    fixed = []
    for seed in range(seeds):
        b = _bench(scan, seed)
        out = Runner(scan, bench=b, seed=seed, frames=n_fixed).run()
        g = find_estimate(out.scan_results, "gain_dn_per_e")
        fixed.append((_met(out.scan_results), g["value"] - _truth_gain(b)))
    err = np.array([p[2] for p in prec])
    ferr = np.array([f[1] for f in fixed])
    d = err - ferr
    return {
        "seeds": seeds, "size": size, "frames": n, "coverage": float(np.mean([p[1] for p in prec])),
        "n_fixed": n_fixed, "fixed_coverage": float(np.mean([f[0] for f in fixed])),
        "frame_ratio": float(n.mean() / n_fixed),
        "gain_err_mean": float(err.mean()), "gain_err_sd": float(err.std(ddof=1)),
        "z_truth": float(err.mean() / (err.std(ddof=1) / math.sqrt(seeds))),
        "z_fixed_truth": float(ferr.mean() / (ferr.std(ddof=1) / math.sqrt(seeds))),
        "z_paired": float(d.mean() / (d.std(ddof=1) / math.sqrt(seeds))) if d.std() > 0 else 0.0,
        "mean_se": float(np.mean([p[3] for p in prec])),
    }
