"""``ares ptc`` wall time and peak memory against the rows of its table (issue 54: it grew
as n^2, 10 000 rows 21.5 s; every table path is now linear).

Each table is a photon-transfer curve with known truth (K 0.5 DN/e-, read variance 20 DN^2,
turnoff at 60 % of the brightest signal, 1 % per-level noise, pixel and frame counts given),
written to a temporary CSV and analysed by ``ares ptc --json`` in a fresh process (the
user's wall time, imports included). The table is printed as Markdown for
``benchmarks/README.md``.

    python benchmarks/bench_ptc_rows.py [--max-rows 1000000]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def write_table(path: Path, n: int, seed: int = 1) -> float:
    rng = np.random.default_rng(seed)
    s = np.linspace(10.0, 50000.0, n)
    t = 30000.0
    v = 20.0 + 0.5 * np.minimum(s, t)
    v = np.where(s > t, v * np.maximum(1 - 5 * (s - t) / t, 0.05), v)
    v *= 1 + 0.01 * rng.standard_normal(n)
    with open(path, "w") as f:
        f.write("mean,var,n_pixels,n_frames\n")
        f.writelines(f"{a:.6f},{b:.6f},10000,2\n" for a, b in zip(s, v))
    return t


def run_once(path: Path) -> tuple[float, float, dict]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    code = ("import resource, sys; from ares.cli import main; rc = main(['ptc', sys.argv[1], '--json']); "
            "sys.stderr.write('MAXRSS %d\\n' % resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); sys.exit(rc)")
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, env=env)
    dt = time.perf_counter() - t0
    rss = next((int(x.split()[1]) for x in p.stderr.splitlines() if x.startswith("MAXRSS")), 0) / 1024
    if p.returncode != 0:
        return dt, rss, {"refused": p.stderr.strip().splitlines()[0][:160]}
    return dt, rss, json.loads(p.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--max-rows", type=int, default=1_000_000)
    a = ap.parse_args()
    sizes = [n for n in (10, 100, 1_000, 10_000, 100_000, 200_000, 1_000_000) if n <= a.max_rows]
    print("| rows | wall time (s) | peak RSS (MB) | s per 1000 rows | K (truth 0.5) | turnoff DN (truth 30000) |")
    print("|---:|---:|---:|---:|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for n in sizes:
            path = Path(d) / f"ptc_{n}.csv"
            write_table(path, n)
            dt, rss, out = run_once(path)
            if "refused" in out:
                print(f"| {n} | {dt:.2f} | {rss:.0f} | - | refused before parsing: {out['refused']} | |", flush=True)
                path.unlink()
                continue
            k, to = out["gain_dn_per_e"], out["turnoff_dn"]
            ks = f"{k['value']:.5f} ± {k['se']:.1g}" if k["value"] is not None else f"n/a ({k.get('note', '')[:40]})"
            ts = f"{to['value']:.0f}" if to["value"] is not None else f"n/a ({to.get('note', '')[:40]})"
            print(f"| {n} | {dt:.2f} | {rss:.0f} | {1000 * dt / n:.3g} | {ks} | {ts} |", flush=True)
            path.unlink()


if __name__ == "__main__":
    main()
