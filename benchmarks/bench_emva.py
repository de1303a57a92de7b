"""EMVA 1288 / photon-transfer benchmark: run time vs error; writes benchmarks/emva.md.

Run on one core::

    OMP_NUM_THREADS=1 taskset -c 0 .venv/bin/python benchmarks/bench_emva.py

1. The EMVA 1288 reference CCD (if ../shared/data/ holds it): time of ``ares emva``'s
   analysis against the time of only decoding the 300 PNGs (baseline, same run), and
   every published value next to ours.
2. Photon transfer on the simulator: conversion-gain error and standard error against
   sensor size and frames per level, with the analysis time (rendering excluded).
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

from ares.analysis.emva.release3 import ATTRIBUTION
from ares.analysis.ptc.levels import stack_stats
from ares.analysis.ptc.photon_transfer import analyze_ptc
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

DESC = Path(__file__).resolve().parents[2] / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / \
    "EMVA1288_Data.txt"
PUBLISHED = {"K": 0.280769, "sigma_y_dark": 3.07342, "u_e_sat": 13972.6, "QE": 45.14, "DSNU1288": 0.5518,
             "PRNU1288": 0.4327, "u_I_mean": 28.41}


def median_s(fn, repeat):
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def reference_section(repeat: int) -> list[str]:
    if not DESC.is_file():
        return ["## EMVA 1288 reference CCD", "", f"Skipped: {DESC} not found.", ""]
    from ares.results.descriptor import analyse_descriptor
    from ares.hardware.emva_descriptor import read_descriptor
    from ares.hardware.imagefile import read_image

    desc = read_descriptor(DESC)
    paths = [p for lv in desc.levels for p in lv.images]
    t_load = median_s(lambda: [read_image(p) for p in paths], repeat)
    an = None

    def run():  # as the command runs it: the numpy paths, numba not loaded (ares.analysis.kernels.jit.avoided)
        nonlocal an
        from ares.analysis.kernels import jit

        with jit.avoided():
            an = analyse_descriptor(desc)

    t_all = median_s(run, repeat)

    def run_kernels():  # the numba kernels, loaded once before the timed runs
        analyse_descriptor(desc)

    run_kernels()
    t_kern = median_s(run_kernels, repeat)
    lines = ["## EMVA 1288 reference CCD (640x480, 12 bit, 300 images)", "",
             "| step | median s | ratio to PNG decoding |", "|---|---:|---:|",
             f"| decode the {len(paths)} PNGs (baseline) | {t_load:.2f} | 1.00 |",
             f"| full `ares emva` analysis (decode + statistics + fits) | {t_all:.2f} | {t_all / t_load:.2f} |",
             f"| the same with the numba kernels, loaded beforehand (not what the command does) | {t_kern:.2f} | "
             f"{t_kern / t_load:.2f} |",
             "", "The full analysis computes every release at once (3.0, 3.1, 4.0 Linear and General): per step "
             "the 4.0 high-pass and row/column/pixel split of the two-image average (Eq. 32), the stacks' "
             "averaged images, spectrograms and histograms. Decoding is ARES's PNG reader (the reference set's "
             "PNGs are unfiltered: CRCs, ISA-L inflate, byte swap; 2.6x faster than Pillow). The statistics are "
             "numpy on exact integers: a pair's sum and a stack's sum are high-passed in integers (int32; int64 "
             "for a long stack's sum), in row blocks of 128 K pixels that stay in a core's cache (binary-doubling "
             "box sums over contiguous memory, ~1.3 ms a VGA image); the numba kernels (pair pass, float low-pass) "
             "are not loaded by the command (their import and first load, ~0.5 s and ~100 MB, would cost more "
             "than they save here). Every image is visited once; benchmarks/peer.md has the whole command "
             "on both cores against the EMVA reference package.",
             "", "| parameter | published | ARES (Release 3.0 definitions) | relative error |",
             "|---|---:|---:|---:|"]
    for k, ref in PUBLISHED.items():
        v = an.emva.values[k].value
        lines.append(f"| {k} | {ref:g} | {v:.6g} | {100 * (v / ref - 1):+.3f} % |")
    lines.append(f"| saturation index | 36 | {an.emva.index_u_ysat} | |")
    lines += ["", f"Data: {ATTRIBUTION}.", ""]
    return lines


def sim_section(repeat: int) -> list[str]:
    try:
        from ares.sim import SensorParams, SimSensor
    except ImportError:
        return ["## Photon transfer on the simulator", "", "Skipped: ares.sim not available.", ""]
    lines = ["## Photon transfer on the simulator: gain error vs data volume", "",
             "24 levels (50 e- .. 1.8x full well), one dark stack; truth G = 0.28 DN/e-; "
             "no defects. Error and SE of the WLS gain; analysis time excludes rendering.", "",
             "| sensor | frames/level | gain error | gain SE | error/SE | analysis ms |",
             "|---|---:|---:|---:|---:|---:|"]
    no = dict(hot_rate_ppm=0, warm_rate_ppm=0, rts_rate_ppm=0, dead_rate_ppm=0, stuck_rate_ppm=0,
              noisy_rate_ppm=0)
    q = np.concatenate([np.geomspace(50, 11000, 20), [12500, 14000, 17000, 22000]])
    for rows, frames in ((64, 2), (64, 8), (128, 4), (256, 2), (256, 8)):
        p = SensorParams(rows=rows, cols=rows, **no)
        s = SimSensor(p, 1)
        t = 0.01
        stacks = [s.render(frames, exposure_s=t, photon_flux=x / (p.qe * t)) for x in q]
        dstack = s.render(max(frames, 4), exposure_s=t, dark=True)
        res = None

        def run():
            nonlocal res
            b = [stack_stats(x, p.max_code) for x in stacks]
            d = stack_stats(dstack, p.max_code)
            res = analyze_ptc(b, [d] * len(b), photons=q / p.qe)

        ms = 1000 * median_s(run, repeat)
        g = res.gain_dn_per_e
        err = g.value / 0.28 - 1
        lines.append(f"| {rows}x{rows} | {frames} | {100 * err:+.3f} % | {100 * g.se / g.value:.3f} % | "
                     f"{(g.value - 0.28) / g.se:+.2f} | {ms:.0f} |")
    lines.append("")
    return lines


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    lines = ["# EMVA 1288 and photon transfer", "",
             f"Generated by `benchmarks/bench_emva.py` on {platform.machine()}, numpy {np.__version__}; "
             "one core. Ratios to the baseline measured in the same run are the stable figures.", ""]
    lines += reference_section(args.repeat)
    lines += sim_section(args.repeat)
    return publish("emva", lines)


if __name__ == "__main__":
    raise SystemExit(main())
