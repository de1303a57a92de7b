"""The window on a large sensor: how long its thread stalls during a scan of a 4096x3072
simulated sensor with the full-frame view on the Results tab, where each statistics
panel of a stage costs 1-2 s. The same scan with those statistics computed in the
window's thread (no stats executor) is the baseline, interleaved, fresh processes.
Writes benchmarks/gui_big.md.

A 10 ms timer in the window's event loop notes when it fires; a stall is a gap between
two firings (what a user feels as a frozen window).

    python benchmarks/bench_gui_big.py [--runs 2] [--frames 8] [--points 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


def child(mode: str, frames: int, points: int) -> dict:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    import bench_big_memory as big
    from PySide6.QtCore import QEventLoop, QTimer
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication([])
    app.setApplicationName("ARES benchmark")  # (kept alive by this reference for the run)
    from ares.gui.main_window import MainWindow

    with tempfile.TemporaryDirectory() as d:
        scan = big.write_inputs(Path(d), frames, points)
        w = MainWindow()
        w.resize(1280, 800)
        w.show()
        if mode == "in place":
            w.session.executor = None
        assert w.load_scan(str(scan))
        w.controls.output.directory.setText(str(Path(d) / "runs"))
        w.view_bar.choose_view("full")
        ticks: list[float] = []
        timer = QTimer()
        timer.setInterval(10)
        timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
        timer.start()
        loop = QEventLoop()
        t0 = time.perf_counter()
        w.start_scan()
        w.scan_thread.finished.connect(loop.quit)
        loop.exec()
        seconds = time.perf_counter() - t0
        timer.stop()
        assert w.session.progress.state == "Done", w.session.progress.message
        n = w.session.panels["MEAN SIGNAL"].stats.n
        assert n == big.ROWS * big.COLS, n  # the full frame's statistics, shown
        gaps = sorted((b - a for a, b in zip(ticks, ticks[1:])), reverse=True)
        w.close()
    return {"seconds": seconds, "longest": gaps[0], "over": sum(g for g in gaps if g > 0.25),
            "count": sum(g > 0.25 for g in gaps)}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--points", type=int, default=3)
    ap.add_argument("--child")
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.frames, args.points)))
        return 0
    modes = ("in place", "stats thread")
    res: dict[str, list[dict]] = {m: [] for m in modes}
    load0 = os.getloadavg()[0]
    for _ in range(args.runs):
        for m in modes:
            r = subprocess.run([sys.executable, __file__, "--child", m, "--frames", str(args.frames),
                                "--points", str(args.points)], capture_output=True, text=True, cwd=ROOT,
                               env=dict(os.environ, QT_QPA_PLATFORM="offscreen"))
            if r.returncode:
                raise SystemExit(f"{m} child failed: {r.stderr[-2000:]}")
            res[m].append(json.loads(r.stdout.strip().splitlines()[-1]))
    load1 = os.getloadavg()[0]
    lines = ["## The window on a 4096x3072 sensor (`bench_gui_big.py`)", "",
             f"`scans/photon_transfer.xml` on `protocols/sim_sensor.xml` at 4096x3072, {args.frames} frames per "
             f"stack, a dark stage and {args.points} light levels; the window offscreen at 1280x800 on the "
             "Results tab with the full-frame view (each statistics panel of a stage: 12.6 M values). A 10 ms "
             "timer in the window's event loop; a stall is a gap between two firings. "
             f"{args.runs} interleaved runs of each, fresh processes, both cores; load average {load0:.1f} at "
             f"the start, {load1:.1f} at the end.", "",
             "| statistics panels | scan s (median) | longest stall s (each run) | stalls > 0.25 s: count, "
             "seconds in all (each run) |", "|---|---:|---|---|"]
    for m in modes:
        rows = res[m]
        lines.append(f"| {'in the window thread (baseline)' if m == 'in place' else 'in the stats thread (ARES)'} "
                     f"| {statistics.median(r['seconds'] for r in rows):.1f} | "
                     + ", ".join(f"{r['longest']:.2f}" for r in rows) + " | "
                     + ", ".join(f"{r['count']}, {r['over']:.1f}" for r in rows) + " |")
    return publish("gui_big", lines)


if __name__ == "__main__":
    sys.exit(main())
