"""Defect classification speed: 1080p, 100 dark frames + 100 flat frames, one core.

Times the full classification (per-pixel statistics of both stacks, every pixel class,
lines, clusters, histograms, RTS pass 2 on the candidates) against a baseline measured in
the same run: numpy's plain ``stack.mean(axis=0)`` and ``stack.var(axis=0)`` over the
same two stacks. Acquisition (generating the stacks) is excluded. Writes
benchmarks/defects.md. Run pinned: ``taskset -c 0`` with OMP_NUM_THREADS=1.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from ares.analysis.defects import classify_defects, classify_stack, pixel_stats  # noqa: E402
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

R, C, F, FF = 1080, 1920, 100, 100
REPEATS = 5


def make_stacks(seed=0):
    rng = np.random.default_rng(seed)
    base = 200 + rng.normal(0, 1.0, (R, C)) + rng.normal(0, 1.0, C)[None, :]
    n = R * C
    idx = rng.choice(n, 6000, replace=False)
    hot, dead, noisy, rts, stuck = np.split(idx, [1500, 3000, 4000, 5000])
    base.ravel()[hot] += rng.uniform(20, 200, hot.size)
    sig = np.full(n, 2.0)
    sig[noisy] = 10.0
    sig = sig.reshape(R, C)
    dark = np.empty((F, R, C), np.uint16)
    flat = np.empty((FF, R, C), np.uint16)
    resp = 2000 * (1 + rng.normal(0, 0.01, (R, C)))
    resp.ravel()[dead] *= 0.3
    for f in range(F):
        z = rng.standard_normal((R, C), dtype=np.float32)
        dark[f] = np.rint(base + z * sig)
        dark[f].ravel()[rts] += np.uint16(20) * (rng.random(rts.size) < 0.5)
        dark[f].ravel()[stuck] = 1000
    for f in range(FF):
        z = rng.standard_normal((R, C), dtype=np.float32)
        flat[f] = np.rint(base + resp + z * np.sqrt(sig**2 + 0.5 * resp))
        flat[f].ravel()[stuck] = 1000
    return dark, flat


def timed(fn):
    ts = []
    out = None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return (statistics.median(ts), min(ts)), out


def main() -> int:
    dark, flat = make_stacks()

    def baseline():
        for s in (dark, flat):
            s.mean(axis=0)
            s.var(axis=0)

    def stats_only():
        pixel_stats(dark)
        pixel_stats(flat)

    def full():
        return classify_stack(dark, flat, gain_dn_per_e=0.5, exposure_s=1.0)

    ds, fs = pixel_stats(dark, 1.0), pixel_stats(flat, 1.0)

    def from_stats():
        return classify_defects(ds, fs, gain_dn_per_e=0.5, rts_series=lambda r, c: dark[:, r, c])

    t_base, _ = timed(baseline)
    t_stats, _ = timed(stats_only)
    t_cls, _ = timed(from_stats)
    t_full, res = timed(full)
    ncpu = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    rows = [
        ("numpy `mean(axis=0)` + `var(axis=0)` over both stacks (baseline)", t_base),
        ("ARES exact per-pixel statistics, both stacks", t_stats),
        ("ARES classification from statistics (all classes, lines, clusters, histograms, RTS pass 2)", t_cls),
        ("ARES full classification (`classify_stack`: statistics + classification)", t_full),
    ]
    md = ["## Defects (`bench_defects.py`)", "",
          f"1080p ({C}x{R}), {F} dark + {FF} flat frames (uint16), {res.counts['total']} defective pixels found; "
          f"{REPEATS} runs on {ncpu} core(s), machine load average {load:.1f} during the run. "
          "Target: full classification <= 2 s on one core.", "",
          "| step | median (s) | best (s) | median vs baseline |", "|---|---:|---:|---:|"]
    md += [f"| {name} | {t[0]:.2f} | {t[1]:.2f} | {t[0] / t_base[0]:.2f}x |" for name, t in rows]
    md += ["", f"Counts: { {k: v for k, v in res.counts.items() if v} }", ""]
    return publish("defects", md)


if __name__ == "__main__":
    sys.exit(main())
