"""Lot throughput (``ares batch`` items): items/s with 1 and 2 local Dask workers, and the
cost of a cached item (cheap key: size, time, first/last 64 KiB) against the full content
hash (``--verify``). Items: 40 synthetic dark stacks of 8 x 256 x 256 (.npy). Every timed
window says how busy the machine was (``machine_load``: the 1-min load average and the CPU
other processes used meanwhile), so a figure taken on a busy machine reads as such.
Runs on all cores (``run_all.ALL_CORES``: 2 workers pinned to one core would measure
nothing). Writes lots.md."""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from machine_load import QUIET, Window  # noqa: E402
from topic_table import publish  # noqa: E402

N_ITEMS = 40


def main() -> int:
    from ares.batch.cluster import make_client, run_items
    from ares.batch.items import STACK, content_hash

    tmp = Path(tempfile.mkdtemp())
    try:
        rng = np.random.default_rng(1)
        items = []
        for i in range(N_ITEMS):
            p = tmp / f"die_{i:03d}.npy"
            np.save(p, (1000 + rng.normal(0, 5, (8, 256, 256))).astype(np.uint16))
            items.append(str(p))
        rows = []
        for w in (1, 2):
            c = make_client(workers=w)
            try:
                run_items(c, items[:2], None)  # warm the workers' imports
                with Window() as analysed:
                    run_items(c, items, str(tmp / f"cache{w}"))
                with Window() as cached:
                    again = run_items(c, items, str(tmp / f"cache{w}"))
                assert all(r["cached"] for r in again)
            finally:
                c.close()
                c.cluster.close()
            rows.append((w, N_ITEMS / analysed.el, analysed, 1e3 * cached.el / N_ITEMS, cached))
        with Window() as quick:
            for p in items:
                content_hash(p, STACK, full=False)
        with Window() as full:
            for p in items:
                content_hash(p, STACK, full=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    q_ms, f_ms = 1e3 * quick.el / N_ITEMS, 1e3 * full.el / N_ITEMS
    busy = any(not win.quiet for r in rows for win in (r[2], r[4]) if win.quiet is not None)
    lines = ["# Lots: items/s and the cost of a cached item", "",
             f"{N_ITEMS} synthetic dark stacks (8 x 256 x 256 uint16, 1 MiB each), `run_items` on a local Dask "
             f"cluster, {os.cpu_count()} cores. The load column is the machine at measurement time "
             f"(`benchmarks/machine_load.py`): 'quiet' when other processes used under {QUIET} core during the "
             "timed window, 'BUSY' otherwise -- a BUSY row's figure is not the machine's.", "",
             "| workers | items/s (analysed) | speed-up vs 1 worker | load while analysing | "
             "ms per cached item (whole round trip) | load while serving the cache |",
             "|---|---:|---:|---|---:|---|"]
    for w, rate, an, ms, ca in rows:
        lines.append(f"| {w} | {rate:.2f} | {rate / rows[0][1]:.2f}x | {an.cell()} | {ms:.1f} | {ca.cell()} |")
    lines += ["", "| cache key | ms per item (in process) | load |", "|---|---:|---|",
              f"| cheap (size, time, first/last 64 KiB) | {q_ms:.3f} | {quick.cell()} |",
              f"| full SHA-256 (`--verify`) | {f_ms:.3f} ({f_ms / q_ms:.1f}x the cheap key) | {full.cell()} |", "",
              "A cached item costs the scheduler round trip, not its key: compare the two tables."]
    if busy:
        lines += ["", "**Measured on a busy machine** (a row above says BUSY): re-run `make bench` "
                      "(or `python benchmarks/bench_lots.py`) on a quiet one before quoting the speed-up."]
    return publish("lots", lines)


if __name__ == "__main__":
    sys.exit(main())
