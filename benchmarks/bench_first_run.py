"""The first `make run` on a fresh machine against the second (issue 40): numba compiles the
simulator's and the analysis' kernels on first use and caches them. Measured with an empty
numba cache (NUMBA_CACHE_DIR in a new folder: what a fresh clone has), the photon-transfer
scan of `make run` run twice, and again with the Makefile's install step (`python -m
ares.jit`, all kernels compiled before the first run) in between. Writes
benchmarks/first_run.md.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parents[1]
SCAN = ROOT / "scans" / "photon_transfer.xml"


def timed(argv: list[str], env: dict) -> tuple[float, str]:
    t0 = time.perf_counter()
    p = subprocess.run(argv, env=env, capture_output=True, text=True, check=True, cwd=ROOT)
    return time.perf_counter() - t0, p.stderr


def main() -> int:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for setup in ("none", "install step"):
            env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / f"cache_{setup[:4]}"), ARES_ANNOUNCE_COMPILE="1")
            warm = None
            if setup != "none":
                warm, _ = timed([sys.executable, "-m", "ares.jit"], env)
            run = [sys.executable, "-m", "ares.cli", "run", str(SCAN), "--quiet"]
            first, err1 = timed(run + ["--out", str(Path(tmp) / f"first_{setup[:4]}")], env)
            second, err2 = timed(run + ["--out", str(Path(tmp) / f"second_{setup[:4]}")], env)
            rows.append((setup, warm, first, second, "compiling" in err1, "compiling" in err2))
    lines = ["## The first run on a fresh machine (`make run`'s scan, empty numba cache)", "",
             "Wall time of `ares run scans/photon_transfer.xml` with an empty numba cache (a fresh clone), "
             "then again; the second row with the Makefile's install step (`python -m ares.jit`: every "
             "kernel compiled before the first run) in between. One run each, same machine, same session.", "",
             "| set-up | install step s | first run s | second run s | first / second | compile notice (1st, 2nd) |",
             "|---|---:|---:|---:|---:|---|"]
    for setup, warm, first, second, n1, n2 in rows:
        lines.append(f"| {setup} | {'' if warm is None else f'{warm:.1f}'} | {first:.1f} | {second:.1f} | "
                     f"{first / second:.2f} | {'yes' if n1 else 'no'}, {'yes' if n2 else 'no'} |")
    lines += ["", "Target: the first run within 1.5x of the second. Without the install step the first run "
              "pays numba's compilation of every kernel and says so on stderr (`ares: compiling the numba kernels "
              "for this machine ..., once`); `make run` and `make test` run the install step when they create "
              ".venv, so a user's first run loads the kernels from the cache."]
    return publish("first_run", lines)


if __name__ == "__main__":
    sys.exit(main())
