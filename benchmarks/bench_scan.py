"""``make run``'s job, whole command, against the same command as it was when the speed
issue was filed (commit BASE), measured in the same run on the same machine.

Both are ``python -m ares.cli run scans/photon_transfer.xml --out DIR -q`` in fresh
processes with the same interpreter and packages, the baseline from a ``git archive`` of
BASE on PYTHONPATH, interleaved (baseline, now, baseline, now...); both cores allowed
and the environment as ``make run`` leaves it (no BLAS/OpenMP variables: what ARES
sets for itself is part of what is measured). Wall time from start to exit (the key
figures, the CSV, HDF5 and PDF all written), CPU time of the process and its children.
Writes benchmarks/scan.md.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parent.parent
BASE = "ff369b1"  # the last commit before the speed work (issue "Speed where the user waits")
PAIRS = 5
OUTPUTS = ("report.pdf", "results.h5", "summary.csv", "ptc.csv", "key_figures.csv", "run.json")


def one(pythonpath: Path, out: Path) -> tuple[float, float]:
    env = {k: v for k, v in os.environ.items()
           if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")}
    env["PYTHONPATH"] = str(pythonpath)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "ares.cli", "run", "scans/photon_transfer.xml", "--out", str(out), "-q"],
                   cwd=pythonpath, env=env, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    missing = [f for f in OUTPUTS if not (out / f).exists()]
    if missing:
        raise SystemExit(f"{out}: {', '.join(missing)} not written")
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def main() -> int:
    with tempfile.TemporaryDirectory() as td:
        base = Path(td) / "base"
        base.mkdir()
        archive = subprocess.run(["git", "archive", BASE], cwd=ROOT, check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
        rows = {"base": [], "now": []}
        for k in range(PAIRS):
            for name, path in (("base", base), ("now", ROOT)):
                rows[name].append(one(path, Path(td) / f"{name}_{k}"))
                print(name, k, [round(x, 2) for x in rows[name][-1]], flush=True)
    load = os.getloadavg()[0]
    med = {n: (statistics.median(w for w, _ in r), statistics.median(c for _, c in r)) for n, r in rows.items()}
    ratios = sorted(b[0] / n[0] for b, n in zip(rows["base"], rows["now"]))
    lines = ["## The main job: `make run` (`ares run scans/photon_transfer.xml`)", "",
             f"26 stages, 432 VGA frames on the simulator, key figures printed, CSV, HDF5 and PDF written; the whole "
             f"command in a fresh process, {PAIRS} interleaved pairs, both cores allowed, the environment as `make run` "
             f"leaves it. Baseline: the same command at commit {BASE} (before the speed work), same interpreter and "
             f"packages. Load average at the end: {load:.1f}.", "",
             "| command | median wall s | median CPU s | runs, wall s |", "|---|---:|---:|---|"]
    for name, label in (("base", f"at {BASE} (baseline)"), ("now", "now")):
        lines.append(f"| {label} | {med[name][0]:.2f} | {med[name][1]:.2f} | "
                     f"{', '.join(f'{w:.2f}' for w, _ in rows[name])} |")
    lines += ["", f"Speed-up (baseline wall / now, per pair): median {statistics.median(ratios):.2f}x "
              f"(pairs {', '.join(f'{r:.2f}' for r in ratios)}); target >= 3x.", ""]
    return publish("scan", lines)


if __name__ == "__main__":
    sys.exit(main())
