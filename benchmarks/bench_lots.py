"""Lot throughput (``ares batch`` items): items/s with 1 and 2 local Dask workers, and the
cost of a cached item (cheap key: size, time, first/last 64 KiB) against the full content
hash (``--verify``). Items: 40 synthetic dark stacks of 8 x 256 x 256 (.npy). Writes lots.md."""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def main(out: Path = Path(__file__).with_name("lots.md")) -> None:
    from ares.batch.cluster import make_client, run_items
    from ares.batch.items import STACK, content_hash

    tmp = Path(tempfile.mkdtemp())
    rng = np.random.default_rng(1)
    items = []
    for i in range(40):
        p = tmp / f"die_{i:03d}.npy"
        np.save(p, (1000 + rng.normal(0, 5, (8, 256, 256))).astype(np.uint16))
        items.append(str(p))
    rows = []
    for w in (1, 2):
        c = make_client(workers=w)
        run_items(c, items[:2], None)  # warm the workers' imports
        t = time.perf_counter()
        run_items(c, items, str(tmp / f"cache{w}"))
        el = time.perf_counter() - t
        t = time.perf_counter()
        again = run_items(c, items, str(tmp / f"cache{w}"))
        cached = time.perf_counter() - t
        assert all(r["cached"] for r in again)
        rows.append((w, len(items) / el, 1e3 * cached / len(items)))
        c.close()
        c.cluster.close()
    t = time.perf_counter()
    for p in items:
        content_hash(p, STACK, full=False)
    quick = 1e3 * (time.perf_counter() - t) / len(items)
    t = time.perf_counter()
    for p in items:
        content_hash(p, STACK, full=True)
    full = 1e3 * (time.perf_counter() - t) / len(items)
    lines = ["# Lots: items/s and the cost of a cached item", "",
             "40 synthetic dark stacks (8 x 256 x 256 uint16, 1 MiB each), `run_items` on a local Dask "
             "cluster, machine shared with other jobs (2 cores).", "",
             "| workers | items/s (analysed) | ms per cached item (whole round trip) | speed-up vs 1 worker |",
             "|---|---|---|---|"]
    for w, rate, ms in rows:
        lines.append(f"| {w} | {rate:.2f} | {ms:.1f} | {rate / rows[0][1]:.2f}x |")
    lines += ["", "| cache key | ms per item (in process) |", "|---|---|",
              f"| cheap (size, time, first/last 64 KiB) | {quick:.3f} |",
              f"| full SHA-256 (`--verify`) | {full:.3f} ({full / quick:.1f}x the cheap key) |", ""]
    out.write_text("\n".join(lines))
    sys.stdout.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
