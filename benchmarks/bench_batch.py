"""``ares batch`` throughput: runs/min and frames/s with 1 and 2 Dask workers on this
machine, against the same items analysed one after the other in this process (the
baseline measured in the same run). Writes ``batch.md``.

Items: N tiny simulated runs (photon transfer, 24 x 32, 4 frames per level) for runs/min,
and one 1080p uint16 stack (.npy) split over the workers for frames/s. Cluster start-up is
measured apart (it is paid once per ``ares batch``)."""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def make_runs(base: Path, n: int) -> list[Path]:
    from test_report import PTC, SCAN, tiny_system

    from ares.cli import main

    system = tiny_system(base / "sim_tiny.xml")
    xml = base / "ptc.xml"
    xml.write_text(SCAN.format(system=system.name, **dict(PTC, extra='<output pdf="false" csv="false"/>')))
    out = []
    for i in range(n):
        d = base / f"r{i:02d}"
        main(["run", str(xml), "--out", str(d), "--seed", str(i), "-q"])
        out.append(d)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=24)
    ap.add_argument("--frames", type=int, default=160)
    ap.add_argument("--out", default=str(Path(__file__).with_name("batch.md")))
    a = ap.parse_args()
    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.batch.cluster import make_client, run_items, split_accumulate
    from ares.batch.items import process

    tmp = Path(tempfile.mkdtemp())
    try:
        runs = make_runs(tmp, a.runs)
        stack = tmp / "stack.npy"
        rng = np.random.default_rng(1)
        np.save(stack, rng.integers(900, 1100, (a.frames, 1080, 1920), dtype=np.uint16))
        t = time.perf_counter()
        for d in runs:
            process(str(d))
        base_runs = time.perf_counter() - t
        t = time.perf_counter()
        acc = StackAccumulator((1080, 1920))
        for f in np.load(stack, mmap_mode="r"):
            acc.add(np.asarray(f))
        acc.merge(StackAccumulator(acc.shape))
        base_stack = time.perf_counter() - t
        rows = [("in this process, one after the other (baseline)", "", base_runs, base_stack)]
        for w in (1, 2):
            t = time.perf_counter()
            c = make_client(workers=w)
            start = time.perf_counter() - t
            run_items(c, [str(d) for d in runs[:2]], None)  # warm the workers' imports and buffers
            split_accumulate(c, str(stack), 2 * w)
            t = time.perf_counter()
            run_items(c, [str(d) for d in runs], None)
            t_runs = time.perf_counter() - t
            t = time.perf_counter()
            split_accumulate(c, str(stack), 2 * w)
            t_stack = time.perf_counter() - t
            c.close()
            c.cluster.close()
            rows.append((f"Dask LocalCluster, {w} worker(s)", f"{start:.1f}", t_runs, t_stack))
        lines = ["## Batch analysis on Dask (`ares batch`)", "",
                 f"{a.runs} tiny simulated runs (key figures as `ares report`), and one 1080p uint16 stack of "
                 f"{a.frames} frames (.npy) accumulated in chunks; median of one pass, 2-core machine. Ratios "
                 "are to the in-process baseline of the same run (workers warmed up first). The runs are tiny "
                 "(~20 ms of analysis each), so Dask's per-task cost (scheduling, moving the result) shows; "
                 "real runs take seconds per item.", "",
                 "| how | cluster start s | runs/min | ratio | stack frames/s | ratio |", "|---|---:|---:|---:|---:|---:|"]
        for name, start, tr, ts in rows:
            lines.append(f"| {name} | {start} | {60 * a.runs / tr:.0f} | {base_runs / tr:.2f} | "
                         f"{a.frames / ts:.0f} | {base_stack / ts:.2f} |")
        lines += ["", "Scaling to N machines: a run directory's analysis is compute per item (reading its small "
                  "JSON/HDF5 files is a fraction of it), so runs/min grows with the workers until the scheduler's "
                  "per-task overhead (~ms) matters -- near linear for items of a second or more. A split stack is "
                  "read where the workers run: each chunk's frames cross the network or the shared file system "
                  "once and only the accumulators (2 x 8 bytes per pixel + per-frame sums) travel back, so "
                  "frames/s scales with the workers while the storage delivers N times the single-reader rate; on "
                  "one machine the memory bus and the disk cap it (two workers on two cores here)."]
        Path(a.out).write_text("\n".join(lines) + "\n")
        print("\n".join(lines))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
