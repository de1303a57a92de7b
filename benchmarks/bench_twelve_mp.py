"""A full EMVA 1288 Release 4.0 measurement on a 12-megapixel sensor: the scan end to end,
then ``ares emva`` against the reference package on its recorded images. Writes
benchmarks/twelve_mp.md (the scan) and benchmarks/twelve_mp_peer.md (the comparison).

    python benchmarks/bench_twelve_mp.py [--rows 3072 --cols 4096] [--skip-scan] [--skip-peer] [--peer-mem-gb 16]
                                         [--peer-python PATH]

1. ``scans/emva_4.xml`` (86 photon-transfer steps with matched darks, 100-image bright and
   dark stacks, 8 dark-current exposures: 560 frames) on ``protocols/sim_sensor.xml`` with
   a 4096x3072 array, run as ``ares run`` runs it (reports included) in a child process:
   wall time, CPU time, peak memory (VmHWM), and the share of each phase -- acquisition
   (the grab loops; of which the simulator's rendering, which a camera does itself),
   the stages' analysis (and the defect mask), the scan-level analyses (EMVA 4.0 sheet,
   photon transfer) and the reports (CSV, HDF5, PDF).
2. The same scan again with ``<output raw_frames="true">`` (same seed: the same frames),
   its frames written out as an EMVA 1288 descriptor set (uncompressed 16-bit TIFFs,
   ``b EXPOSURE_NS PHOTONS`` / ``d EXPOSURE_NS`` records), then ``ares emva`` and the
   reference package ``emva1288`` 1.0.2 (its own venv, as ``bench_peer.py``) on those
   files: wall, CPU, peak memory. The peer runs under an address-space limit
   (``--peer-mem-gb``) so that it cannot take the machine down: where it stops
   (memory, time) is reported as such. ``--peer-python`` names an interpreter that already
   has ``emva1288`` (e.g. a venv made by hand under /tmp) instead of ``bench_peer.py``'s.
   At another size than 4096x3072 the comparison goes to ``twelve_mp_peer_COLSxROWS.md``,
   so a smaller set measured beside the 12 MP one does not overwrite it.

Ratios are within this run; the load average at the start and end is given, since the
machine is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine_load import Window  # (beside this script)
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
TARGET_GB = 2.0

CHILD = r"""
import json, resource, sys, time
from ares.cli import tune_malloc
tune_malloc()  # as ``ares run`` does
from ares.protocol.scan import load_scan
from ares.scan import Runner, events as ev
import ares.scan.runner as R
import ares.rig.factory as F
benches = []
_build = F.build_bench
def build(*a, **k):
    b = _build(*a, **k)
    benches.append(b)
    return b
F.build_bench = build
spent = {"acquisition": 0.0, "stage analysis and defect mask": 0.0, "scan-level analyses": 0.0, "reports": 0.0}
for name, phase in (("analyze_stage", "stage analysis and defect mask"), ("mask_from_dark", "stage analysis and defect mask")):
    f = getattr(R, name)
    def wrap(*a, _f=f, _p=phase, **k):
        t = time.perf_counter()
        try:
            return _f(*a, **k)
        finally:
            spent[_p] += time.perf_counter() - t
    setattr(R, name, wrap)
grab = R.Runner._grab
def timed_grab(self, *a, **k):
    t = time.perf_counter()
    try:
        return grab(self, *a, **k)
    finally:
        spent["acquisition"] += time.perf_counter() - t
R.Runner._grab = timed_grab
ending = []
def lis(e):
    if isinstance(e, ev.Ending):
        ending.append(time.perf_counter())
t0 = time.perf_counter()
r = Runner(load_scan(sys.argv[1]), out_dir=sys.argv[2], seed=1, defer_reports=True)
r.add_listener(lis)
out = r.run()
t1 = time.perf_counter()
spent["scan-level analyses"] = t1 - ending[0] if ending else 0.0
r.write_reports()
spent["reports"] = time.perf_counter() - t1
wall = time.perf_counter() - t0
ru = resource.getrusage(resource.RUSAGE_SELF)
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
sim = benches[0].frames if benches else None
print(json.dumps({"status": out.status, "wall": wall, "cpu": ru.ru_utime + ru.ru_stime, "hwm_mb": int(hwm) / 1024,
                  "spent": spent, "sim_s": getattr(sim, "compute_seconds", None)}))
"""


def write_inputs(d: Path, rows: int, cols: int, raw: bool) -> Path:
    (d / "protocols").mkdir(parents=True)
    (d / "scans").mkdir()
    sysxml = (ROOT / "protocols" / "sim_sensor.xml").read_text()
    for old, new in (('rows="480" cols="640"', f'rows="{rows}" cols="{cols}"'),
                     ('name="rows" type="int" value="480"', f'name="rows" type="int" value="{rows}"'),
                     ('name="cols" type="int" value="640"', f'name="cols" type="int" value="{cols}"')):
        if old not in sysxml:
            raise SystemExit("protocols/sim_sensor.xml no longer declares a 640x480 array: update this benchmark")
        sysxml = sysxml.replace(old, new)
    (d / "protocols" / "sim_sensor.xml").write_text(sysxml)
    scan = (ROOT / "scans" / "emva_4.xml").read_text()
    out = '<output raw_frames="false" hdf5="true" csv="true" pdf="true"/>'
    if out not in scan:
        raise SystemExit("scans/emva_4.xml's <output> changed: update this benchmark")
    if raw:  # the recording run: frames kept, no reports
        scan = scan.replace(out, '<output raw_frames="true" hdf5="false" csv="false" pdf="false"/>')
    p = d / "scans" / "emva_4.xml"
    p.write_text(scan)
    return p


def run_child(scan: Path, run_dir: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-c", CHILD, str(scan), str(run_dir)], capture_output=True, text=True,
                       cwd=ROOT, env=env, timeout=4 * 3600)
    if p.returncode:
        raise SystemExit(p.stderr[-3000:])
    return json.loads(p.stdout.strip().splitlines()[-1])


def write_descriptor(run_dir: Path, d: Path, bits: int = 12) -> tuple[Path, int]:
    """The recorded frames of ``run_dir`` as an EMVA 1288 descriptor set in ``d``."""
    import h5py
    import numpy as np
    from PIL import Image

    (d / "img").mkdir(parents=True)
    lines, n_img, shape = ["v 4.0"], 0, None
    for sj in sorted((run_dir / "stages").glob("*.json")):
        st = json.loads(sj.read_text())
        s = st["settings"]
        if st.get("scene") == "dark":  # (the dark-current exposures: the reference package wants a bright
            continue  # level at every exposure; both tools get the same set)
        exp_ns = float(s["exposure"]) * 1e9
        fh = run_dir / "frames" / (sj.stem + ".h5")
        with h5py.File(fh, "r") as f:
            for key in ("dark", "frames"):
                if key not in f or len(f[key]) == 0:
                    continue
                ds = f[key]
                shape = ds.shape[1:]
                dark = key == "dark" or st.get("scene") == "dark"
                lines.append(f"d {exp_ns:.1f}" if dark else f"b {exp_ns:.1f} {float(s['light']) * float(s['exposure']):.3f}")
                for i in range(len(ds)):
                    name = f"img/{sj.stem}_{key}_{i:03d}.tif"
                    Image.fromarray(np.asarray(ds[i], np.uint16)).save(d / name)
                    lines.append(f"i {name}")
                    n_img += 1
    lines.insert(1, f"n {bits} {shape[1]} {shape[0]}")
    p = d / "EMVA1288_Data.txt"
    p.write_text("\n".join(lines) + "\n")
    return p, n_img


PEER_LIMITED = """
import resource, sys
lim = int(float(sys.argv[2]) * 2**30)
resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
from emva1288 import process
process.Emva1288(sys.argv[1]).results()
"""


def peer_run(py: Path, desc: Path, mem_gb: float, timeout_s: float):
    """(wall, CPU, peak MiB, None) or (wall, CPU, peak MiB, why it stopped)."""
    import bench_peer as bp

    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    argv = [str(py), "-c", bp.WRAP, PEER_LIMITED, str(desc), str(mem_gb)]
    t = time.perf_counter()
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT, env=env)
    try:
        _, err = p.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        p.kill()
        _, err = p.communicate()
        why = f"stopped after {timeout_s / 60:.0f} min (time limit)"
    else:
        why = None
    wall = time.perf_counter() - t
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime
    text = err.decode(errors="replace")
    hwm = float(text.rsplit("VmHWM_kB", 1)[1].split()[0]) / 1024 if "VmHWM_kB" in text else float("nan")
    if why is None and p.returncode:
        last = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("VmHWM")][-1:]
        why = ("stopped: out of memory under its " + f"{mem_gb:g} GiB limit ({last[0][:120]})"
               if "MemoryError" in text else f"exit {p.returncode}: {last[0][:160] if last else ''}")
    return wall, cpu, hwm, why


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=3072)
    ap.add_argument("--cols", type=int, default=4096)
    ap.add_argument("--skip-scan", action="store_true")
    ap.add_argument("--skip-peer", action="store_true")
    ap.add_argument("--peer-mem-gb", type=float, default=16.0)
    ap.add_argument("--peer-timeout-min", type=float, default=90.0)
    ap.add_argument("--peer-python", default=None, help="a Python that has emva1288 1.0.2 (default: bench_peer's venv)")
    ap.add_argument("--work", default=None, help="folder for the recorded set (needs ~14 GB at 4096x3072)")
    ap.add_argument("--descriptor", default=None, help="a set this script recorded before (its EMVA1288_Data.txt): "
                                                       "not recorded again")
    args = ap.parse_args()
    load0 = os.getloadavg()[0]
    mp = args.rows * args.cols / 1e6
    size = f"{args.cols}x{args.rows} ({mp:.1f} Mpx)"
    with tempfile.TemporaryDirectory(dir=args.work) as td:
        td = Path(td)
        if not args.skip_scan:
            with Window() as w:
                r = run_child(write_inputs(td / "a", args.rows, args.cols, raw=False), td / "a" / "run")
            lines = [f"## EMVA 1288 4.0 on a {args.cols}x{args.rows} sensor (`bench_twelve_mp.py`)", "",
                     f"`scans/emva_4.xml` (86 photon-transfer steps with matched darks, 100-image bright and dark "
                     f"stacks, 8 dark-current exposures: 560 frames) on `protocols/sim_sensor.xml` at {size}, as "
                     f"`ares run` runs it, reports included; status {r['status']}. {platform.machine()}, "
                     f"{os.cpu_count()} cores, Python {platform.python_version()}.", "",
                     "| figure | value | machine load |", "|---|---:|---|",
                     f"| wall time | {r['wall'] / 60:.1f} min | {w.cell()} |",
                     f"| CPU time (both cores) | {r['cpu'] / 60:.1f} min | {w.cell()} |",
                     f"| peak memory (VmHWM; target {TARGET_GB:.0f} GB) | **{r['hwm_mb'] / 1024:.2f} GiB** "
                     f"({r['hwm_mb'] * 2**20 / 1e9:.2f} GB) | {w.cell()} |"]
            for k, v in r["spent"].items():
                lines.append(f"| {k} | {v / 60:.1f} min ({100 * v / r['wall']:.0f} %) | {w.cell()} |")
            if r.get("sim_s") is not None:
                lines.append(f"| of the acquisition: the simulator rendering frames (a camera's work) | "
                             f"{r['sim_s'] / 60:.1f} min ({100 * r['sim_s'] / r['wall']:.0f} %) | {w.cell()} |")
            publish("twelve_mp", lines + _load_line(load0))
        if not args.skip_peer:
            topic = "twelve_mp_peer" if (args.rows, args.cols) == (3072, 4096) else f"twelve_mp_peer_{args.cols}x{args.rows}"
            publish(topic, _peer(args, td, size, mp) + _load_line(load0))
    return 0


FLOOR = r"""
import json, os, sys, time
from concurrent.futures import ThreadPoolExecutor
from ares import malloc
malloc.tune()
from ares.hardware import tiff
from ares.hardware.emva_descriptor import read_checked, read_descriptor
desc = read_descriptor(sys.argv[1])
paths = list(dict.fromkeys(p for lv in desc.levels for p in lv.images))
def raw(p):
    with open(p, "rb") as f:
        return len(f.read())
fast = tiff.read
def pillow(p):
    tiff.read = lambda f, m: None  # (Pillow for every file)
    try:
        return read_checked(desc, p)
    finally:
        tiff.read = fast
readers = {"the files' bytes only (no decode)": raw, "ARES (`ares.hardware.tiff`, as `ares emva`)":
           lambda p: read_checked(desc, p), "Pillow (as `ares emva` before)": pillow}
got = {name: [] for name in readers}
with ThreadPoolExecutor(os.cpu_count()) as ex:
    for r in range(3):  # interleaved rounds, each reader first once: medians
        for name in list(readers)[r % 3:] + list(readers)[:r % 3]:
            list(ex.map(readers[name], paths[:4]))
            t, c = time.perf_counter(), time.process_time()
            list(ex.map(readers[name], paths))
            got[name].append((time.perf_counter() - t, time.process_time() - c))
print(json.dumps({k: [sorted(x[i] for x in v)[1] for i in (0, 1)] for k, v in got.items()}))
"""


SHARES = r"""
from ares.cli import set_blas_threads
set_blas_threads()  # one BLAS thread, as ares emva (cli.main): the default threads spin in np.dot and overstate its CPU
import collections, json, sys, time
import concurrent.futures as cf
from ares import malloc
from ares.analysis.kernels import jit
malloc.tune()
class Serial:  # the analysis on one thread, so that each part's process CPU time is its own
    def __init__(self, *a, **k): pass
    def __enter__(self): return self
    def __exit__(self, *a): return False
    def submit(self, fn, *a, **k):
        f = cf.Future(); f.set_result(fn(*a, **k)); return f
    def map(self, fn, it): return [fn(x) for x in it]
cf.ThreadPoolExecutor = Serial
from ares.commands import emva
from ares.analysis.spatial import nonuniformity as emva_spatial
from ares.analysis.ptc import levels
from ares.hardware import emva_descriptor
import ares.analysis.emva.release3, ares.analysis.emva.sheet, ares.analysis.emva.general_table, ares.analysis.ptc.photon_transfer
spent = collections.Counter()
def wrap(mod, name, label):
    real = getattr(mod, name)
    def f(*a, **k):
        c = time.process_time()
        try:
            return real(*a, **k)
        finally:
            spent[label] += time.process_time() - c
    setattr(mod, name, f)
wrap(emva_descriptor, "read_checked", "reading and checking the images (decode)")
wrap(emva_spatial, "split", "spatial variances of every step and stack (the 4.0 high-pass, Sections 4.2, 8.1)")
wrap(levels, "pair_moments", "pair moments (sums, squares, the pair's sum image)")
import contextlib
c0 = time.process_time()
big = emva.uses_kernels(emva_descriptor.read_descriptor(sys.argv[1]))
with contextlib.nullcontext() if big else jit.avoided():  # as ares emva: numba's kernels for a large set only
    emva.analyse_descriptor(sys.argv[1])
spent["total"] = time.process_time() - c0
print(json.dumps(spent))
"""


def emva_shares(desc: Path) -> list[str]:
    """Where ``ares emva``'s analysis spends its CPU time (one thread, process CPU per part)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    with Window() as w:
        p = subprocess.run([sys.executable, "-c", SHARES, str(desc)], capture_output=True, text=True, cwd=ROOT,
                           env=env, timeout=3600)
    if p.returncode:
        raise SystemExit(p.stderr[-2000:])
    spent = json.loads(p.stdout.strip().splitlines()[-1])
    tot = spent.pop("total")
    out = ["", f"Where `ares emva`'s analysis spends its CPU time (run on one thread so that each part's process "
               f"CPU time is its own; {tot:.1f} s in all; {w.cell()}):", "", "| part | CPU s | share |", "|---|---:|---:|"]
    for k, v in sorted(spent.items(), key=lambda kv: -kv[1]):
        out.append(f"| {k} | {v:.1f} | {100 * v / tot:.0f} % |")
    rest = tot - sum(spent.values())
    out.append(f"| the rest (fits, graphs, tables, the stacks' other sums) | {rest:.1f} | {100 * rest / tot:.0f} % |")
    d = 100 * spent.get("reading and checking the images (decode)", 0.0) / tot
    sp = 100 * max((v for k, v in spent.items() if k.startswith("spatial")), default=0.0) / tot
    return out + ["", f"Decoding, which the reference package pays as well, is {d:.0f} % of this CPU time: were it free, "
                      f"`ares emva` would be at most {100 / (100 - d):.2f} times as fast as here. Of the analysis, the "
                      f"spatial variances of every step (Section 4.2 with the 4.0 high-pass of Section 8.1, for the "
                      f"mandatory graph of spatial variances per step) take {sp:.0f} %."]


def decode_floor(desc: Path) -> dict:
    """(wall s, CPU s) of reading every image of the set: bytes only, ARES's reader, Pillow."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-c", FLOOR, str(desc)], capture_output=True, text=True, cwd=ROOT, env=env,
                       timeout=3600)
    if p.returncode:
        raise SystemExit(p.stderr[-2000:])
    return json.loads(p.stdout.strip().splitlines()[-1])


def _load_line(load0: float) -> list[str]:
    return ["", f"Load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end (other work on the "
                "machine lengthens the wall times; CPU time and memory are less affected).", ""]


def _peer(args, td: Path, size: str, mp: float) -> list[str]:
    import bench_peer as bp

    py = Path(args.peer_python) if args.peer_python else bp.peer_python()
    if args.descriptor:
        desc, rec = Path(args.descriptor), {"status": "done, recorded before"}
        n = sum(1 for ln in desc.read_text().splitlines() if ln.startswith("i "))
    else:
        rec = run_child(write_inputs(td / "b", args.rows, args.cols, raw=True), td / "b" / "run")
        desc, n = write_descriptor(td / "b" / "run", td / "set")
        shutil.rmtree(td / "b" / "run" / "frames")
    print(f"descriptor set: {n} images", flush=True)
    ares = [sys.executable, bp.ARES, "emva", str(desc)]
    bp.measured(ares)  # bytecode cached, files in the page cache where they fit
    with Window() as wa:
        aw, ac, am, _ = bp.measured(ares)
    print(f"ares emva: {aw:.1f} s, {am:.0f} MiB", flush=True)
    lines = [f"## `ares emva` against the reference package on a {size} set (`bench_twelve_mp.py`)", "",
             f"The recorded images of `scans/emva_4.xml` at {size} (recording run status {rec['status']}): the "
             f"photon-transfer steps and the two 100-image stacks, {n} uncompressed 16-bit TIFFs "
             f"({n * mp * 2 / 1e3:.1f} GB), as an EMVA 1288 descriptor set (the dark-current exposures left out: "
             "the reference package wants a bright level at every exposure). The reference package ran under a "
             f"{args.peer_mem_gb:g} GiB address-space limit.", "",
             "| command | wall s | CPU s | peak RSS MiB | wall vs peer | memory vs peer | machine load |",
             "|---|---:|---:|---:|---:|---:|---|"]
    mine = f"| `ares emva` (every release) | {aw:.1f} | {ac:.1f} | {am:.0f} |"
    if py is None:
        return lines + [f"{mine} | | {wa.cell()} |", "",
                        "The reference package's venv could not be made: no comparison."]
    with Window() as wp:
        pw, pc, pm, why = peer_run(py, desc, args.peer_mem_gb, args.peer_timeout_min * 60)
    if why is None:
        with Window() as wf:
            floor = decode_floor(desc)
        lines += [f"| `emva1288` 1.0.2 (baseline) | {pw:.1f} | {pc:.1f} | {pm:.0f} | 1.00 | 1.00 | {wp.cell()} |",
                  f"{mine} {pw / aw:.1f}x faster | {am / pm:.2f} | {wa.cell()} |", "",
                  f"`ares emva` against the reference package on the same files: **{pw / aw:.1f}x** faster "
                  f"(target 4x), **{am / pm:.2f}** of its peak memory (target 0.5).", "",
                  f"Reading the set, which both pay (the {n} images on {os.cpu_count()} threads, in one process, "
                  f"after its imports; medians of 3 interleaved rounds; {wf.cell()}):", "",
                  "| reader | wall s | CPU s | of `ares emva`'s wall | of the peer's wall |", "|---|---:|---:|---:|---:|"]
        for name, (w, c) in floor.items():
            lines.append(f"| {name} | {w:.2f} | {c:.2f} | {100 * w / aw:.0f} % | {100 * w / pw:.0f} % |")
        return lines + emva_shares(desc)

    return lines + [f"| `emva1288` 1.0.2 | {why}: after {pw:.0f} s | {pc:.1f} | {pm:.0f} | | | {wp.cell()} |",
                    f"{mine} | | {wa.cell()} |", "",
                    f"The reference package did not finish on this set ({why}); `ares emva` did, in {aw:.0f} s at "
                    f"{am / 1024:.2f} GiB."]


if __name__ == "__main__":
    raise SystemExit(main())
