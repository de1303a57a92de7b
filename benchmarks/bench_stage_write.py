"""Writing a stage's arrays (``stages/NNNN.h5``): the maps a VGA stage stores (mean,
variance and dark mean, float32 with noise) with the first filter (gzip level 4) as the
baseline, the second (byte shuffle + gzip level 1) and the current one: float maps
uncompressed (integer maps such as the defect mask keep shuffle + gzip-1). Writes
benchmarks/stage_write.md.
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
    base_t, base_b = rows[0][1], rows[0][2]
    lines = ["## Stage arrays to HDF5 (`stages/NNNN.h5`)", "",
             f"Three float32 640x480 noise maps per stage; median of {REPEATS} writes.", "",
             "| filter | ms per stage | ratio | kB | size ratio |", "|---|---:|---:|---:|---:|"]
    lines += [f"| {label} | {1e3 * t:.1f} | {t / base_t:.2f} | {b // 1024} | {b / base_b:.2f} |"
              for label, t, b in rows]
    return publish("stage_write", lines)


if __name__ == "__main__":
    sys.exit(main())
