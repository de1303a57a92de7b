"""The null table of the telegraph likelihood ratio (``ares.analysis.defects.rts.telegraph_lr``):
its upper quantiles over white standard normal series of F frames (fixed seed), which the
classifier compares a noisy pixel's ratio with (``rts.HMM_NULL``), and the false-alarm rate
those thresholds give on an independent draw (measured, not assumed).

    python benchmarks/bench_defect_hmm_null.py            # prints the table for rts.py, writes defect_hmm_null.md
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from ares.analysis.defects.rts import HMM_NULL_FRAMES, HMM_NULL_P, hmm_null_threshold, telegraph_lr

OUT = Path(__file__).with_name("defect_hmm_null.md")
N = 100_000
CHECK = (12, 16, 20, 24, 32, 48, 64, 100, 128, 200, 256)


def draw(f: int, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.concatenate([telegraph_lr(rng.standard_normal((f, min(20_000, n - i)))) for i in range(0, n, 20_000)])


def main() -> None:
    t0 = time.time()
    if "--table" in sys.argv:
        rows = []
        for f in HMM_NULL_FRAMES:
            lr = draw(f, N, 20261207 + f)
            rows.append(f"    {f}: ({', '.join(f'{np.quantile(lr, 1 - p):.3f}' for p in HMM_NULL_P)}),")
            print(rows[-1], flush=True)
        return
    lines = ["# Telegraph likelihood-ratio null: measured false-alarm rate", "",
             f"White standard normal series, {N} per frame count, drawn with seeds the table (rts.HMM_NULL) was "
             "not made from; the fraction whose ratio reaches the stored threshold at each p (a frame count "
             "between two table rows uses the larger of their thresholds).", "",
             "| frames | " + " | ".join(f"p = {p:g}" for p in HMM_NULL_P) + " |",
             "|---:|" + "---:|" * len(HMM_NULL_P)]
    for f in CHECK:
        lr = draw(f, N, 7_000_000 + f)
        cells = [f"{np.mean(lr >= hmm_null_threshold(f, p)):.2g}" for p in HMM_NULL_P]
        lines.append(f"| {f} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    lines += ["", f"Binomial SE of a rate p over {N} series: sqrt(p / {N}) (1e-4 at p = 1e-3), to which the table's "
              "own Monte Carlo error (as many series) adds as much again.", "",
              f"{time.time() - t0:.0f} s on a 2-core machine shared with other jobs."]
    OUT.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
