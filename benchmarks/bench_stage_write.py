"""Writing a stage's arrays (``stages/NNNN.h5``): the maps a VGA stage stores (mean,
variance and dark mean, float32 with noise) with the first filter (gzip level 4) as the
baseline, the second (byte shuffle + gzip level 1) and the current one: float maps
uncompressed (integer maps such as the defect mask keep shuffle + gzip-1). Then the
integrity record the writer adds to every stage (``ares.rundir.check.array_sha256`` of each map,
hashed in memory as it is written) against that write and against a stage of ``make run``
(benchmarks/scan.md). Writes benchmarks/stage_write.md.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
from machine_load import Window  # (benchmarks/machine_load.py, beside this script)
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

REPEATS = 9


def maps(seed=0):
    rng = np.random.default_rng(seed)
    base = 2000 + rng.normal(0, 20, (480, 640))
    return {"mean": (base + rng.normal(0, 1.5, base.shape)).astype(np.float32),
            "variance": (600 + rng.normal(0, 40, base.shape)).astype(np.float32),
            "dark_mean": (64 + rng.normal(0, 0.3, base.shape)).astype(np.float32)}


def write(path, arrays, **filt) -> float:
    t0 = time.perf_counter()
    with h5py.File(path, "w") as f:
        for k, a in arrays.items():
            f.create_dataset(k, data=a, chunks=a.shape, **filt)
    return time.perf_counter() - t0


def main() -> int:
    arrays = maps()
    rows = []
    with tempfile.TemporaryDirectory() as td:
        p = Path(td) / "s.h5"
        for label, filt in (("gzip 4 (first, baseline)", dict(compression="gzip", compression_opts=4)),
                            ("shuffle + gzip 1 (second)", dict(compression="gzip", compression_opts=1, shuffle=True)),
                            ("no compression (now, float maps)", {})):
            t = statistics.median(write(p, arrays, **filt) for _ in range(REPEATS))
            rows.append((label, t, os.path.getsize(p)))
    from ares.rundir.check import array_sha256

    def hash_all() -> float:
        t0 = time.perf_counter()
        for a in arrays.values():
            array_sha256(a)
        return time.perf_counter() - t0

    with Window() as load:
        t_hash = statistics.median(hash_all() for _ in range(REPEATS))
    base_t, base_b = rows[0][1], rows[0][2]
    lines = ["## Stage arrays to HDF5 (`stages/NNNN.h5`)", "",
             f"Three float32 640x480 noise maps per stage; median of {REPEATS} writes.", "",
             "| filter | ms per stage | ratio | kB | size ratio |", "|---|---:|---:|---:|---:|"]
    lines += [f"| {label} | {1e3 * t:.1f} | {t / base_t:.2f} | {b // 1024} | {b / base_b:.2f} |"
              for label, t, b in rows]
    lines += ["", f"Integrity record (SHA-256 of the three maps, `ares.rundir.check`): {1e3 * t_hash:.1f} ms a stage, "
              f"{t_hash / rows[-1][1]:.2f}x the uncompressed write"
              + (_of_a_scan_stage(t_hash) if load.quiet else "; its share of a `make run` stage is not given: "
                 "scan.md was measured on a quiet machine and this was not") + f". Machine: {load.cell()}."]
    return publish("stage_write", lines)


def _of_a_scan_stage(t_hash: float) -> str:
    """``, N % of a make-run stage`` from benchmarks/scan.md's "now" row (26 VGA stages)."""
    import re

    try:
        m = re.search(r"^\| now \| ([0-9.]+) \|", (Path(__file__).with_name("scan.md")).read_text(), re.M)
    except OSError:
        m = None
    if not m:
        return ""
    stage = float(m.group(1)) / 26
    return f", {100 * t_hash / stage:.1f} % of a `make run` stage ({1e3 * stage:.0f} ms: scan.md, 26 stages)"


if __name__ == "__main__":
    sys.exit(main())
