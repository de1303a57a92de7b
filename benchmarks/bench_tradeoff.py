"""`ares bench scans/photon_transfer.xml` with its full default grid: run time against each key
figure's error on the simulator. Writes benchmarks/tradeoff.md (the Pareto settings per
figure and the recommendation) and benchmarks/tradeoff.png (the plot)."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parents[1]
FIGS = {"gain_ptc": "gain, PTC fit", "gain_one_level": "gain, one level", "read_noise": "read noise",
        "full_well": "full well"}


def main() -> int:
    with tempfile.TemporaryDirectory() as td:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "ares.cli", "bench", str(ROOT / "scans" / "photon_transfer.xml"),
                        "--out", td, "-q"], check=True, cwd=ROOT)
        took = time.perf_counter() - t0
        rows = list(csv.DictReader(open(Path(td) / "bench.csv")))
        info = json.loads((Path(td) / "bench.json").read_text())
        shutil.copy(Path(td) / "bench.png", Path(__file__).parent / "tradeoff.png")
    seeds = rows[0]["seeds"]
    lines = ["## Run time against accuracy: `ares bench scans/photon_transfer.xml`", "",
             f"Full default grid ({len(rows)} settings: frames 2/4/8/16, levels 9/17/25 log and linear, sensor "
             f"64/128/256 px square, shot noise auto/exact) x {seeds} seeds on the defect-free simulated sensor, one "
             f"core, {took / 60:.0f} min. Error = the larger of the RMS error against the truth and the mean "
             "reported SE, relative. The Pareto settings of each figure (no other setting is both faster and more "
             "accurate):", "",
             "| figure | setting | time per run s | bias % | spread % | mean SE % |", "|---|---|---:|---:|---:|---:|"]
    for key, name in FIGS.items():
        front = sorted((r for r in rows if r[f"{key}_pareto"] == "1"), key=lambda r: float(r["time_s"]))
        for r in front:
            lines.append(f"| {name} | {r['setting']} | {float(r['time_s']):.2f} | {r[f'{key}_bias_pct'] or 'n/a'} | "
                         f"{r[f'{key}_spread_pct'] or 'n/a'} | {r[f'{key}_se_pct'] or 'n/a'} |")
    lines += ["", f"Recommended for the default targets (gain 0.5 %, read noise 2 %): {info['recommendation']}.", "",
              "![error against time](tradeoff.png)"]
    return publish("tradeoff", lines)


if __name__ == "__main__":
    sys.exit(main())
