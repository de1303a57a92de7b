"""Suite time: test files run in one pytest process (no xdist) with OpenBLAS's default
threads (one per core: ``ARES_BLAS_THREADS`` = the core count, what the suite's processes had
before tests/conftest.py set ARES's own BLAS setting) and with ARES's one thread, the two
interleaved in the same session; wall time and the CPU the run used (user + system of the
pytest process and everything it started). Writes benchmarks/suite_time_blas.md (the full suite before/after: suite_time.md).

    python benchmarks/bench_suite_time.py [TEST_FILE ...]
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

from machine_load import Window  # (benchmarks/machine_load.py, beside this script)
from topic_table import publish

ROOT = Path(__file__).resolve().parents[1]
FILES = ["tests/test_emva4_truth.py", "tests/test_scan_truth.py", "tests/test_emva_reference.py",
         "tests/test_emva_spatial_kernel.py"]


def timed(files: list[str], threads: int) -> tuple[float, float, str]:
    env = dict(os.environ, ARES_BLAS_THREADS=str(threads), QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(ROOT))
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with Window() as w:
        t0 = time.perf_counter()
        rc = subprocess.call([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                              "-m", "not study", *files], cwd=ROOT, env=env, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if rc:
        raise SystemExit(f"pytest {' '.join(files)} failed (exit {rc}) with {threads} BLAS threads")
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), w.cell()


def main() -> int:
    files = sys.argv[1:] or FILES
    cores = os.cpu_count() or 1
    rows = []
    for f in files:
        before = timed([f], cores)
        after = timed([f], 1)
        rows.append((f, before, after))
    lines = ["## Suite time: BLAS threads in the test processes", "",
             f"One pytest process per file (no xdist), OpenBLAS's default ({cores} threads, one per core) then "
             "ARES's one thread (`ares.cli.set_blas_threads`, which tests/conftest.py now calls before numpy "
             "loads), in the same session; CPU = user + system of pytest and what it started.", "",
             "| file | wall s before | wall s after | CPU s before | CPU s after | CPU ratio | load (before / after) |",
             "|---|---:|---:|---:|---:|---:|---|"]
    for f, (wb, cb, lb), (wa, ca, la) in rows:
        lines.append(f"| {f} | {wb:.1f} | {wa:.1f} | {cb:.1f} | {ca:.1f} | {ca / cb:.2f} | {lb} / {la} |")
    return publish("suite_time_blas", lines)


if __name__ == "__main__":
    raise SystemExit(main())
