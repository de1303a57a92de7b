"""Run every benchmarks/bench_*.py pinned to one core and rebuild benchmarks/README.md.

Each bench script measures its own baseline in the same run (figures are ratios, since
these machines are shared and noisy) and writes its table to benchmarks/<topic>.md
(``topic_table.publish``); this script runs them and concatenates the tables under a
common header. README.md is only ever this concatenation: a section written by hand goes in
a topic file of its own (``ptc_rows.md``), or the next rebuild drops it.

    python benchmarks/run_all.py [--only sim,accumulate] [--no-run]
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
HEADER = """# ARES benchmarks

Speed and memory are measured here, never asserted in tests. Every figure is a median of
repeated runs on ONE core (`taskset -c 0`, BLAS/OpenMP threads = 1), reported next to a
baseline measured in the same run, because the machines are shared and noisy. Re-run
with `make bench` (or `python benchmarks/run_all.py --only TOPIC`).

"""


ALL_CORES = {"batch", "estimates", "eta", "first_run", "gui", "gui_big", "lots", "scan", "peer", "live_pipeline", "twelve_mp"}  # batch, lots: 1 vs 2 workers; eta: the commit thread beside the frames; gui, gui_big: the window thread next to the scan; scan: make run; peer: ares emva vs emva1288; live_pipeline: the grab thread beside the window's; twelve_mp: a 12 MP EMVA 4.0 scan and ares emva vs emva1288; estimates: every shipped scan as ares run runs it


def readme_lines() -> list[str]:
    p = HERE / "README.md"
    return p.read_text().splitlines() if p.exists() else []


def section(text: str) -> str:
    """A topic file as a section of the README: a file written as a document of its own (its
    first heading "# ") has every heading demoted one level, so each topic is a "## " section
    under the README's one title (headings inside ``` blocks are code, left alone)."""
    lines = text.splitlines()
    first = next((ln for ln in lines if ln.startswith("#")), "")
    if not first.startswith("# "):
        return text
    out, code = [], False
    for ln in lines:
        code ^= ln.startswith("```")
        out.append("#" + ln if not code and ln.startswith("#") else ln)
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="", help="comma-separated topics (bench_<topic>.py)")
    ap.add_argument("--no-run", action="store_true", help="only rebuild README.md from the topic tables")
    args = ap.parse_args()
    only = {t for t in args.only.split(",") if t}
    scripts = sorted(HERE.glob("bench_*.py"))
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    pin = ["taskset", "-c", "0"] if shutil.which("taskset") else []
    failed = []
    if not args.no_run:
        for script in scripts:
            topic = script.stem.removeprefix("bench_")
            if only and topic not in only:
                continue
            print(f"== {script.name}", flush=True)
            t0 = time.perf_counter()
            cores = [] if topic in ALL_CORES else pin  # the batch benchmark measures 1 vs 2 workers
            rc = subprocess.call(cores + [sys.executable, str(script)], env=env, cwd=HERE.parent)
            print(f"   ({time.perf_counter() - t0:.0f} s, exit {rc})", flush=True)
            if rc:
                failed.append(script.name)
    last = (f"Last run: {time.strftime('%Y-%m-%d')} on {platform.machine()}, "
            f"Python {platform.python_version()}, {os.cpu_count()} cores (one used).")
    if args.no_run:  # nothing was run: the date of the last run stays
        last = next((line for line in readme_lines() if line.startswith("Last run: ")), last)
    parts = [HEADER, last + "\n"]
    for md in sorted(HERE.glob("*.md")):
        if md.name == "README.md":
            continue
        parts.append("\n" + section(md.read_text().strip()) + "\n")
    (HERE / "README.md").write_text("\n".join(parts))
    if failed:
        print("failed:", ", ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
