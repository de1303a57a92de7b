"""Does the live pipeline keep up with a 4096x3072 camera at 30 frames/s? Writes
benchmarks/live_pipeline.md.

    python benchmarks/bench_live_pipeline.py [--frames 16] [--points 4] [--runs 2]

``scans/photon_transfer.xml`` (its views: the full frame, the regions, the Bayer and ADC
channels) on ``protocols/sim_sensor.xml`` at 4096x3072, run by the scan runner as ``ares
run`` and the window run it, with the simulator's frame rendering taken out: the first
frames of each kind (dark, lit) are rendered once, then served again from memory, as a
camera hands over finished frames. What is timed is the runner's grab loop per frame --
accumulation for every view (13 components' sums), the defect-masked sums once the mask
exists, clip counters, the preview and progress events -- plus the stack's compaction
(amortised over its frames). A 30 frames/s stream leaves 33.3 ms a frame.

Three modes, fresh processes, interleaved:

* baseline: a frame copied once (``np.copyto``, 24 MiB) -- the least any pipeline does;
* headless: the runner alone (``ares run``);
* headless, one thread: the same with the fused sums kernel on one core (``ARES_FOLD_THREADS=1``);
* window: the runner under the window (offscreen, 1280x800, Results tab, full-frame view),
  whose thread receives every preview and progress event; its longest stall (10 ms timer)
  and how long after the last frame it was idle again are given beside.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine_load import Window  # (beside this script)
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
BUDGET_MS = 1000.0 / 30.0
NOTE = ("Issue 40, what changed (profiled with the threads' CPU clocks and getrusage's system time): the fused "
        "kernel is split into bands of rows on two threads (`int_fold.threads()`; integer sums, the same bits; "
        "`ARES_FOLD_THREADS=1` keeps one), so the grab thread carries half of it; each new stack's int64 sums, "
        "batch store and masked shift were new memory, 0.2-0.6 s of system time a 4096x3072 stack on this VM "
        "(12-35 ms a frame of a 16-frame stack), and are now handed from a collected stack to the next "
        "(`ares.analysis.kernels.recycle`, frames above 4 Mpx; emptied before each stage's analysis, so the peak is "
        "unchanged); the masked view no longer forms a reference cycle with its full-frame stack (each stack's "
        "250 MB waited for a full garbage collection), its shift is made without temporaries and the mask's "
        "coordinates are kept across stacks. Left above the floor, per stack: the stack the run keeps for a "
        "later reused dark is not recycled, so one stack of two per stage still takes new memory; zeroing the "
        "recycled sums; the masked view's shift and line plan. The whole process's CPU (both threads) is what a "
        "30 frames/s stream needs from the machine: on 2 cores the budget is 2 x 33.3 ms of CPU, and the grab "
        "thread's own share must stay under 33.3 ms.")
DISTINCT = 4
RENDERED = [0]  # stacks the simulator really rendered (left out of the timing)


def _serve_from_memory() -> None:
    """Render each kind of frame once per exposure setting, then hand the same arrays out."""
    from ares.sim.sensor import SimSensor

    real = SimSensor.render
    cache: dict = {}

    def render(self, n, **kw):
        # dark or lit (light off counts as dark): every lit level gets the first lit frames, the cost is the same
        key = bool(kw.get("dark")) or not float(kw.get("photon_flux", 0.0)) > 0
        have = cache.setdefault(key, [])
        if len(have) < DISTINCT:
            have.append(real(self, n, **kw))
            RENDERED[0] += 1
            return have[-1]
        have.append(have.pop(0))  # four different frames of each kind, in turn
        return have[-1][:n]

    SimSensor.render = render


def _time_grabs(times: list) -> None:
    """Wrap the runner's grab loop: (seconds, frames) per stack."""
    import ares.scan.runner as R

    real = R.Runner._grab

    def grab(self, bench, st, n, *a, **k):
        r0, t, c, p = RENDERED[0], time.perf_counter(), time.thread_time(), time.process_time()
        out = real(self, bench, st, n, *a, **k)
        times.append((time.perf_counter() - t, n, RENDERED[0] != r0, time.thread_time() - c, time.process_time() - p))
        return out

    R.Runner._grab = grab


def child(mode: str, frames: int, points: int) -> dict:
    import numpy as np

    import bench_big_memory as big

    if mode == "baseline":
        rng = np.random.default_rng(0)
        src = rng.integers(0, 4096, (big.ROWS, big.COLS), dtype=np.uint16)
        dst = np.empty_like(src)
        np.copyto(dst, src)
        t, c, p = time.perf_counter(), time.thread_time(), time.process_time()
        for _ in range(frames * 4):
            np.copyto(dst, src)
        c, p = (time.thread_time() - c) / (frames * 4), (time.process_time() - p) / (frames * 4)
        out = {"per_frame_s": (time.perf_counter() - t) / (frames * 4), "cpu_per_frame_s": c, "proc_per_frame_s": p}
        # the floor of this design: the fused sums kernel alone (one read of each pixel for its
        # sums, squares, row/column sums and clip counts), on the runner's 2-frame block
        from ares.analysis.kernels import int_fold
        from ares.scan.stage_analysis import batch_for

        b = batch_for(src.shape)
        blk = np.stack([src ^ np.uint16(0x8000)] * b).view(np.int16)
        s1, s2, cnt = np.zeros(src.shape, np.int64), np.zeros(src.shape, np.int64), np.zeros(2, np.int64)
        if int_fold.fold(blk, 1 << 15, s1, s2, 4095, cnt) is not None:
            n = (frames // b) * b
            for parts, key in ((None, "kernel"), (1, "kernel1")):  # as the runner folds, and on one core
                t, c, p = time.perf_counter(), time.thread_time(), time.process_time()
                for _ in range(frames // b):
                    int_fold.fold(blk, 1 << 15, s1, s2, 4095, cnt, parts=parts)
                out.update({f"{key}_per_frame_s": (time.perf_counter() - t) / n,
                            f"{key}_cpu_per_frame_s": (time.thread_time() - c) / n,
                            f"{key}_proc_per_frame_s": (time.process_time() - p) / n})
            out["threads"] = int_fold.threads()
        return out
    from ares.cli import tune_malloc

    tune_malloc()  # as ``ares run`` and ``ares gui`` do
    _serve_from_memory()
    times: list = []
    _time_grabs(times)
    with tempfile.TemporaryDirectory() as d:
        scan_path = big.write_inputs(Path(d), frames, points)
        text = scan_path.read_text().replace('pdf="true"', 'pdf="false"')
        scan_path.write_text(text)
        extra: dict = {}
        if mode.startswith("headless"):
            from ares.protocol.scan import load_scan
            from ares.scan import Runner

            out = Runner(load_scan(scan_path), out_dir=Path(d) / "run", seed=1, defer_reports=True).run()
            status = out.status
        else:
            os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
            from PySide6.QtCore import QEventLoop, QTimer
            from PySide6.QtWidgets import QApplication

            app = QApplication.instance() or QApplication([])
            from ares.gui.main_window import MainWindow

            w = MainWindow()
            w.resize(1280, 800)
            w.show()
            assert w.load_scan(str(scan_path))
            w.controls.output.directory.setText(str(Path(d) / "runs"))
            w.view_bar.choose_view("full")
            ticks: list[float] = []
            timer = QTimer()
            timer.setInterval(10)
            timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
            timer.start()
            loop = QEventLoop()
            w.start_scan()
            w.scan_thread.finished.connect(loop.quit)
            loop.exec()
            t_end = time.perf_counter()
            for _ in range(50):  # the window's queue after the runner's thread ended
                app.processEvents()
            timer.stop()
            gaps = sorted((b - a for a, b in zip(ticks, ticks[1:])), reverse=True)
            extra = {"longest_stall_s": gaps[0] if gaps else 0.0, "drain_s": time.perf_counter() - t_end}
            status = w.session.progress.state
            w.close()
            del app
    kept = [(s / n, c / n, p / n) for s, n, rendered, c, p in times if n and not rendered]  # rendered: left out
    return dict(extra, status=status, per_frame_s=statistics.median(k[0] for k in kept),
                cpu_per_frame_s=statistics.median(k[1] for k in kept),
                proc_per_frame_s=statistics.median(k[2] for k in kept),
                worst_stack_per_frame_s=max(k[0] for k in kept), stacks=len(kept))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=16)
    ap.add_argument("--points", type=int, default=4)
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--child")
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.frames, args.points)))
        return 0
    modes = ("baseline", "headless", "headless1", "window")
    res: dict[str, list[dict]] = {m: [] for m in modes}
    loads: dict[str, list[Window]] = {m: [] for m in modes}
    load0 = os.getloadavg()[0]
    for _ in range(args.runs):
        for m in modes:
            with Window() as w:
                    r = subprocess.run([sys.executable, __file__, "--child", m, "--frames", str(args.frames),
                                    "--points", str(args.points)], capture_output=True, text=True, cwd=ROOT,
                                   env=dict(os.environ, QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(ROOT),
                                            **({"ARES_FOLD_THREADS": "1"} if m == "headless1" else {})),
                                   timeout=3600)
            loads[m].append(w)
            if r.returncode:
                raise SystemExit(f"{m} child failed: {r.stderr[-3000:]}")
            res[m].append(json.loads(r.stdout.strip().splitlines()[-1]))
            print(m, res[m][-1], flush=True)
    load1 = os.getloadavg()[0]
    med = {m: statistics.median(x["per_frame_s"] for x in res[m]) * 1e3 for m in modes}
    cpu = {m: statistics.median(x["cpu_per_frame_s"] for x in res[m]) * 1e3 for m in modes}
    proc = {m: statistics.median(x.get("proc_per_frame_s", x["cpu_per_frame_s"]) for x in res[m]) * 1e3 for m in modes}
    base = med["baseline"]

    def load(m: str) -> str:  # the busiest of the mode's runs
        return max(loads[m], key=lambda w: (w.others or 0.0)).cell()

    lines = ["## The live pipeline against a 30 frames/s 4096x3072 camera (`bench_live_pipeline.py`)", "",
             f"`scans/photon_transfer.xml` at 4096x3072 (12.6 Mpx, 24 MiB a frame), {args.frames} frames per "
             f"stack, a dark stage and {args.points} light levels with matched darks; the simulator's rendering "
             "taken out (frames served from memory as a camera delivers them). Per frame: the runner's grab loop "
             "(every view's sums, the defect-masked sums, clip counts, preview and progress events) and the stack's "
             "compaction, amortised; median over the stacks after the first of each kind, then over "
             f"{args.runs} interleaved fresh-process runs. {platform.machine()}, {os.cpu_count()} cores, Python "
             f"{platform.python_version()}; load average {load0:.1f} at the start, {load1:.1f} at the end "
             "(other work on the machine inflates every row alike).", "",
             "| pipeline | ms per frame | vs the copy | vs 33.3 ms (30 frames/s) | CPU ms per frame (grab thread) "
             "| CPU ms per frame (whole process) | notes | machine load |",
             "|---|---:|---:|---:|---:|---:|---|---|"]

    def row(label, wall, c, p, note, m):
        lines.append(f"| {label} | {wall:.1f} | {wall / base:.1f} | {wall / BUDGET_MS:.2f} | {c:.1f} | {p:.1f} | "
                     f"{note} | {load(m)} |")

    row("one copy of the frame (baseline)", base, cpu["baseline"], proc["baseline"], "", "baseline")
    if all("kernel_per_frame_s" in x for x in res["baseline"]):
        k = {}
        for key in ("kernel1", "kernel"):
            for w, name in (("", "per_frame_s"), ("c", "cpu_per_frame_s"), ("p", "proc_per_frame_s")):
                k[key + w] = statistics.median(x[f"{key}_{name}"] for x in res["baseline"]) * 1e3
        nt = res["baseline"][0].get("threads", 1)
        row("the fused sums kernel alone on one core (`int_fold`, one read of each pixel)", k["kernel1"], k["kernel1c"],
            k["kernel1p"], "the least the stack's sums cost one core", "baseline")
        row(f"the same kernel split over {nt} threads (bands of rows, as the runner folds)", k["kernel"], k["kernelc"],
            k["kernelp"], "the same sums, bit for bit", "baseline")
        row("copy + kernel on one core (the floor of one thread)", k["kernel1"] + base, k["kernel1c"] + cpu["baseline"],
            k["kernel1p"] + proc["baseline"], "a frame the source may reuse is copied once", "baseline")
        row(f"copy + kernel over {nt} threads (the floor of this machine)", k["kernel"] + base,
            k["kernelc"] + cpu["baseline"], k["kernelp"] + proc["baseline"], "", "baseline")
    for m, label in (("headless1", "runner alone, the kernel on one core (`ARES_FOLD_THREADS=1`)"),
                     ("headless", "runner alone (`ares run`)"), ("window", "runner under the window")):
        note = ""
        if m == "window":
            note = ("longest stall of the window " + ", ".join(f"{x['longest_stall_s']:.2f}" for x in res[m])
                    + " s; idle again " + ", ".join(f"{x['drain_s']:.2f}" for x in res[m]) + " s after the last frame")
        row(label, med[m], cpu[m], proc[m], note, m)
    worst = max(med["headless"], med["window"])
    verdict = "keeps up with" if worst <= BUDGET_MS else "does not keep up with"
    busy = any(not w.quiet for ws in loads.values() for w in ws if w.quiet is not None)
    lines += ["", f"The pipeline {verdict} 30 frames/s on this machine{' as loaded' if busy else ''}: "
              f"**{med['headless']:.1f} ms** a frame alone ({med['headless1']:.1f} ms with the kernel on one core), "
              f"**{med['window']:.1f} ms** under the window (budget {BUDGET_MS:.1f} ms); the whole process's CPU time "
              f"(both threads of the fold; other processes inflate it far less than the wall time) is "
              f"**{proc['headless']:.1f} ms** and **{proc['window']:.1f} ms** a frame.", "", NOTE, ""]
    return publish("live_pipeline", lines)


if __name__ == "__main__":
    raise SystemExit(main())
