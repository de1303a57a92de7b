"""Start-up time of the command line: ``ares --help`` against ``python -c pass`` (baseline,
same interpreter, same run). The commands import numpy, scipy and the analysis only when
they run, so the parser is built from light modules. Writes benchmarks/startup.md.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

REPEATS = 15


def median_s(argv: list[str]) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    base = median_s([sys.executable, "-c", "pass"])
    rows = [("python -c pass (baseline)", base)]
    for label, argv in (("ares --help", ["--help"]), ("ares run --help", ["run", "--help"]),
                        ("ares defects --help", ["defects", "--help"]),
                        ("ares validate scans/photon_transfer.xml", ["validate", "scans/photon_transfer.xml"])):
        rows.append((label, median_s([sys.executable, "-m", "ares.cli", *argv])))
    lines = ["## Start-up: `ares --help`", "",
             f"Median wall time of {REPEATS} runs each, with the interpreter's own start as baseline.", "",
             "| command | median s | ratio to baseline |", "|---|---:|---:|"]
    lines += [f"| {label} | {s:.3f} | {s / base:.2f} |" for label, s in rows]
    lines += ["", "`ares validate` loads no scipy, matplotlib, h5py or Qt (a test checks it): the simulator's "
              "normal table, the 4.0 high-pass factors and the defect classifier are built or imported on first use "
              "(before: 1.5 s, scipy.stats and scipy.signal at import)."]
    return publish("startup", lines)


if __name__ == "__main__":
    sys.exit(main())
