"""Run every shipped scan on the simulator with few frames and render every page of its
report to PNG (one montage per scan) for a visual review:

    .venv/bin/python tests/review_reports.py OUT_DIR [--frames N]

(emva_reference.xml needs ../shared/data; emva_4.xml runs with its own frame counts.)"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from pdfrender import montage, render  # noqa: E402

from ares.cli import main  # noqa: E402


def review(out: Path, frames: int) -> None:
    for scan in sorted((HERE.parent / "scans").glob("*.xml")):
        run = out / scan.stem
        t = time.perf_counter()
        args = ["run", str(scan), "--out", str(run), "--seed", "1", "--quiet"]
        if scan.stem not in ("emva_4", "emva_reference"):
            args += ["--frames", str(frames)]
        rc = main(args)
        pdfs = sorted(run.glob("*.pdf"))
        pages = [p for pdf in pdfs for p in render(pdf, out / "png" / scan.stem, 0.8)]
        if pages:
            montage(pages, out / f"{scan.stem}.png")
        print(f"{scan.stem:16s} exit {rc}  {len(pages)} page(s)  {time.perf_counter() - t:.1f} s", flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--frames", type=int, default=4)
    a = ap.parse_args()
    review(Path(a.out), a.frames)
