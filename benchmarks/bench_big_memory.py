"""Peak memory of a photon-transfer scan on a 4096x3072 simulated sensor, by phase; writes
benchmarks/big_memory.md.

    python benchmarks/bench_big_memory.py [--points 4] [--frames 32]

The shipped ``protocols/sim_sensor.xml`` and ``scans/photon_transfer.xml`` with the array
set to 4096x3072 (12.6 Mpx), ``--frames`` frames per stack and ``--points`` light levels
(a dark stage, then flats with their matched darks), written to a temporary directory
and run in a child process: a sampler thread there records the resident set (VmRSS,
every 20 ms) per phase of the run -- building the bench, each stage's frames, the defect
mask, each stage's analysis, the scan-level analyses, the reports (the PDF drawn in this
process: the report helper of ``ares run`` is a separate process with its own memory) --
and the whole process's high-water mark (VmHWM). The child sets glibc's allocator as
``ares run`` does (``ares.malloc``; ``BENCH_MALLOC=none`` leaves glibc's defaults). Baseline in the same child: the
interpreter with ARES's scan modules imported; the figures are also given in uint16 frames
(24 MiB each).
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parents[1]
ROWS, COLS = 3072, 4096
TARGET_GB = 2.0

CHILD = r"""
import json, sys, threading, time
def rss():
    for l in open("/proc/self/status"):
        if l.startswith("VmRSS"):
            return int(l.split()[1]) / 1024
phase = ["imports"]; peak = {}; order = []; stop = [False]
def sampler():
    while not stop[0]:
        r, k = rss(), phase[0]
        if k not in peak:
            order.append(k)
        peak[k] = max(peak.get(k, 0.0), r)
        time.sleep(0.02)
import os
if os.environ.get("BENCH_MALLOC") != "none":
    from ares.cli import tune_malloc
    tune_malloc()  # as ``ares run`` does
from ares.protocol.scan import load_scan
from ares.scan import Runner, events as ev
import ares.scan.runner as R
threading.Thread(target=sampler, daemon=True).start()
base = rss()
def lis(e):
    if isinstance(e, ev.StageStarted):
        phase[0] = f"stage {e.index + 1}: frames"
    elif isinstance(e, ev.Ending):
        phase[0] = "scan-level analyses"
for name in ("analyze_stage", "mask_from_dark"):
    f = getattr(R, name)
    def wrap(*a, _f=f, _n=name, **k):
        old = phase[0]
        phase[0] = (old.split(":")[0] + ": analysis") if _n == "analyze_stage" else "defect mask"
        try:
            return _f(*a, **k)
        finally:
            phase[0] = old
    setattr(R, name, wrap)
scan = load_scan(sys.argv[1])
phase[0] = "opening the run directory and the simulated bench"
r = Runner(scan, out_dir=sys.argv[2], seed=1, defer_reports=True)  # the runner's own bench, as in ares run
r.add_listener(lis)
out = r.run()
phase[0] = "reports (CSV, HDF5, PDF)"
r.write_reports()
time.sleep(0.05)
stop[0] = True
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
print(json.dumps({"status": out.status, "base": base, "hwm": int(hwm) / 1024,
                  "phases": [[k, peak[k]] for k in order]}))
"""


def write_inputs(d: Path, frames: int, points: int) -> Path:
    (d / "protocols").mkdir()
    (d / "scans").mkdir()
    sysxml = (ROOT / "protocols" / "sim_sensor.xml").read_text()
    sysxml = sysxml.replace('rows="480" cols="640"', f'rows="{ROWS}" cols="{COLS}"')
    sysxml = sysxml.replace('name="rows" type="int" value="480"', f'name="rows" type="int" value="{ROWS}"')
    sysxml = sysxml.replace('name="cols" type="int" value="640"', f'name="cols" type="int" value="{COLS}"')
    if str(ROWS) not in sysxml:
        raise SystemExit("protocols/sim_sensor.xml no longer declares a 640x480 array: update this benchmark")
    (d / "protocols" / "sim_sensor.xml").write_text(sysxml)
    scan = (ROOT / "scans" / "photon_transfer.xml").read_text()
    scan = scan.replace("<frames>16</frames>", f"<frames>{frames}</frames>")
    scan = scan.replace('frames="32"', f'frames="{frames}"').replace('dark_frames="32"', f'dark_frames="{frames}"')
    scan = scan.replace('points="25"', f'points="{points}"')
    p = d / "scans" / "pt.xml"
    p.write_text(scan)
    return p


def main() -> int:
    import json

    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=4)
    ap.add_argument("--frames", type=int, default=32)  # the shipped dark stage: its frames kept (256 MiB in memory)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as td:
        scan = write_inputs(Path(td), args.frames, args.points)
        p = subprocess.run([sys.executable, "-c", CHILD, str(scan), str(Path(td) / "run")], capture_output=True,
                           text=True, cwd=ROOT, timeout=3600)
    if p.returncode:
        raise SystemExit(p.stderr[-3000:])
    r = json.loads(p.stdout.strip().splitlines()[-1])
    frame_mb = ROWS * COLS * 2 / 2**20
    lines = ["## Memory of a 4096x3072 scan (`bench_big_memory.py`)", "",
             f"`scans/photon_transfer.xml` on `protocols/sim_sensor.xml` with a {COLS}x{ROWS} array (one uint16 frame: "
             f"{frame_mb:.0f} MiB), {args.frames} frames per stack, a dark stage and {args.points} light levels with "
             f"their matched darks; stages pipelined as `ares run` does (off above 4 Mpx). Resident memory of the run's "
             f"process by phase, peak of each (sampled every 20 ms); {platform.machine()}, Python "
             f"{platform.python_version()}. Run status: {r['status']}.", "",
             "| phase | peak RSS MiB | in uint16 frames |", "|---|---:|---:|",
             f"| ARES's scan modules imported (baseline) | {r['base']:.0f} | |"]
    for k, v in r["phases"]:
        if k != "imports":
            lines.append(f"| {k} | {v:.0f} | {v / frame_mb:.0f} |")
    worst = max(r["phases"], key=lambda x: x[1])
    from ares.protocol.scan import load_scan
    from ares.scan.preflight import memory_bytes
    from ares.scan.stages import expand

    with tempfile.TemporaryDirectory() as td:  # the estimate `ares validate` prints for this scan
        sc = load_scan(write_inputs(Path(td), args.frames, args.points))
        est = memory_bytes(sc, expand(sc, None)) / 2**30
    lines += ["", f"High-water mark of the process: **{r['hwm'] / 1024:.2f} GiB** (target {TARGET_GB:.0f} GB), "
                  f"highest in: {worst[0]}. The estimate `ares validate` gives for this scan: {est:.2f} GiB.", ""]
    return publish("big_memory", lines)


if __name__ == "__main__":
    raise SystemExit(main())
