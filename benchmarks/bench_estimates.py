"""The memory and disk estimates of ``ares validate`` / ``ares run --dry-run`` against what a
run really takes; writes benchmarks/estimates.md (and the measured figures to
benchmarks/estimates.json, so that ``--reuse`` can recompute the estimate column after a
change of the model without running the scans again).

    python benchmarks/bench_estimates.py [--only NAME,...] [--timeout 1800] [--reuse] [--cold]

The kernels are cached first (``python -m ares.jit``), the case the estimate assumes;
``--cold`` measures the chosen scans as a first run instead (an empty NUMBA_CACHE_DIR for
each child), stored and shown as separate ', first run' rows.

Every shipped scan (``scans/*.xml``) whose system can run here, as shipped, then two scans
on ``protocols/sim_sensor.xml`` with a 4096x3072 array: ``scans/photon_transfer.xml`` with
4 light levels and 32 frames per stack (the ``bench_big_memory.py`` scan) and a short
``scans/emva_4.xml`` (8 photon-transfer exposures, 8-frame stacks, 2 dark-current
exposures: the full 560-frame scan takes over 20 minutes at this size; its per-pixel maps,
which set the peak, are the same). Each runs as ``ares run SCAN --out DIR --quiet`` in a
child process (``ares.cli.main``: glibc's allocator tuned, the PDF helper process started as
``ares run`` starts it -- its memory is its own and is not in the figure); measured: the
child's high-water mark (VmHWM) and the run directory's size. The estimates are
``ares.scan.preflight.memory_bytes`` and ``disk_bytes`` of the same scan.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_twelve_mp import write_inputs  # (benchmarks/, beside this script)
from machine_load import Window
from topic_table import publish

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent
ROWS, COLS = 3072, 4096
WITHIN = 0.10  # the estimate's target: within 10 % of the measured peak

CHILD = r"""
import json, sys
from ares.cli import main
rc = main(["run", sys.argv[1], "--out", sys.argv[2], "--quiet"])
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
print(json.dumps({"rc": rc, "hwm": int(hwm) * 1024}))
"""


def big_inputs(d: Path, which: str) -> Path:
    """``which`` = "photon_transfer" or "emva_4" on a 4096x3072 sim_sensor (written as
    ``bench_twelve_mp.py`` writes it), shortened as the module docstring says."""
    import re

    write_inputs(d, ROWS, COLS, raw=False)  # protocols/sim_sensor.xml at 4096x3072 and scans/emva_4.xml
    scan = (ROOT / "scans" / f"{which}.xml").read_text()
    if which == "photon_transfer":
        scan = scan.replace("<frames>16</frames>", "<frames>32</frames>").replace('points="25"', 'points="4"')
    else:
        vals = "0.0002 0.002 0.004 0.006 0.008 0.012 0.0152 0.0164"
        scan = re.sub(r"<values>.*?</values>", f"<values>{vals}</values>", scan, flags=re.S)
        scan = scan.replace('frames="100" dark_frames="100"', 'frames="8" dark_frames="8"')
        scan = scan.replace('points="8"', 'points="2"')
    p = d / "scans" / f"{which}_12mp.xml"
    p.write_text(scan)
    return p


def du(path: Path) -> int:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


def warm_kernels() -> None:
    """The numba kernels cached, as ``make`` installs them (``python -m ares.jit``; a no-op
    when they are): the estimate's case, so no row's peak includes numba compiling in-process."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-m", "ares.jit"], cwd=ROOT, env=env, check=True, capture_output=True)


def measure(scan: Path, run_dir: Path, timeout: float, cold: bool = False) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if cold:  # a first run on a machine: an empty numba cache, every kernel compiled in the run
        env["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="ares_cold_numba_")
    # the libraries' share measured just before the run, as `python -m ares.jit` measures it:
    # their resident pages differ by up to ~70 MiB with the machine's state (page cache), so a
    # row's estimate takes the share measured in the same state as its peak
    from ares.memory_base import measure as measure_base

    base = measure_base()
    with Window() as w:
        try:
            p = subprocess.run([sys.executable, "-c", CHILD, str(scan), str(run_dir)], capture_output=True,
                               text=True, cwd=ROOT, env=env, timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"error": f"not finished in {timeout:.0f} s"}
    if p.returncode or not p.stdout.strip():
        return {"error": (p.stderr.strip().splitlines() or ["no output"])[-1][:200]}
    r = json.loads(p.stdout.strip().splitlines()[-1])
    if r["rc"]:  # a run that ended with an error (4: limits failed) is shown so, with its last line
        said = [ln for ln in p.stderr.strip().splitlines() if ln.strip() and "Warning" not in ln
                and "tracemalloc" not in ln]
        r["said"] = (said or [""])[-1][:120]
    r.update(disk=du(run_dir), seconds=w.el, base=base, load=w.cell(), when=time.strftime("%Y-%m-%d %H:%M"),
             kernels="compiled in the run" if cold else "cached")
    return r


def estimates(scan: Path, cold: bool = False, base: float | None = None) -> tuple[float, float]:
    from ares.protocol import load_scan
    from ares.scan.preflight import disk_bytes, memory_bytes
    from ares.scan.stages import expand

    sc = load_scan(scan)
    st = expand(sc, None)
    return memory_bytes(sc, st, kernels_cached=not cold, import_bytes=base), disk_bytes(sc, st)


def cases(td: Path) -> list[tuple[str, Path]]:
    out = []
    for p in sorted((ROOT / "scans").glob("*.xml")):
        out.append((p.stem, p))
    out.append(("photon_transfer at 4096x3072 (4 levels, 32 frames)", big_inputs(td / "pt", "photon_transfer")))
    out.append(("emva_4 at 4096x3072, short (8 steps, 8-frame stacks)", big_inputs(td / "e4", "emva_4")))
    return out


def _exit(r: dict) -> str:
    if not r.get("rc"):
        return ""
    said = r.get("said", "")
    return f"; the run exited {r['rc']}" + (f" ({said})" if said and "Warning" not in said else "")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="", help="comma-separated starts of row names ('photon' matches the shipped "
                    "scans photon_*, 'photon_transfer at' the 4096x3072 row)")
    ap.add_argument("--timeout", type=float, default=1800.0)
    ap.add_argument("--reuse", action="store_true", help="take the measured figures from estimates.json")
    ap.add_argument("--cold", action="store_true", help="measure with an empty numba cache (a first run), "
                    "stored and shown as separate rows ('NAME, first run')")
    args = ap.parse_args()
    if not args.reuse:
        warm_kernels()
    store = HERE / "estimates.json"
    old = json.loads(store.read_text()) if store.exists() else {}
    rows = []
    with tempfile.TemporaryDirectory() as td:
        for base, scan in cases(Path(td)):
            for cold in (False, True):
                name = f"{base}, first run" if cold else base
                wanted = [o for o in args.only.split(",") if o]
                picked = not wanted or any(base.startswith(o) and (" " in o) == (" " in base) for o in wanted)
                if args.reuse or not picked or cold != args.cold:
                    r = old.get(name)
                    if r is None and cold:
                        continue  # first-run rows are shown only where measured
                else:
                    try:
                        estimates(scan)  # a scan this machine cannot run (data, package) is said so
                    except Exception as exc:  # noqa: BLE001 - the benchmark reports it and goes on
                        r = {"error": f"not run: {str(exc)[:160]}"}
                    else:
                        r = measure(scan, Path(td) / "runs" / "".join(c if c.isalnum() else "_" for c in name), args.timeout, cold)
                    old[name] = r  # (merged with what another run of this script stored meanwhile)
                    store.write_text(json.dumps({**(json.loads(store.read_text()) if store.exists() else {}),
                                                 name: r}, indent=1) + "\n")
                    print(name, r, flush=True)
                try:
                    mem, disk = estimates(scan, cold, (r or {}).get("base"))
                except Exception:  # noqa: BLE001
                    mem = disk = None
                rows.append((name, r, mem, disk))
    gib = 2 ** 30
    lines = ["## Memory and disk estimates against a run (`bench_estimates.py`)", "",
             f"Each scan run as `ares run SCAN --out DIR --quiet` in a child process ({platform.machine()}, Python "
             f"{platform.python_version()}); peak = the process's VmHWM (the PDF helper process is not in it), disk = "
             "the run directory's size at the end. Estimates: `ares.scan.preflight.memory_bytes` / `disk_bytes`, as "
             f"`ares validate` prints them. Target: memory within {WITHIN:.0%} of the peak. Rows without ', first run' "
             "ran with numba's kernels cached (`python -m ares.jit` first, as `make` installs them: the case the "
             "estimate assumes and names); ', first run' rows with an empty NUMBA_CACHE_DIR, the kernels compiled in "
             "the run (`--cold`; the estimate adds `COMPILE_BYTES`). The libraries' share of the base is measured on "
             "the machine at install (`python -m ares.jit` records what importing them takes, `ares.memory_base`; "
             "two installs of the same day, with newer numba and numpy in the second, differ by 36 MiB; each row's "
             "estimate takes the share measured just before its run, since the libraries' resident pages vary "
             "with the machine's page cache: 170 to 242 MiB on one machine in one day), the rest of the model is "
             "fitted: `RUN_BYTES`, `MASKED_HEAP_BYTES`, `PRECISION_BYTES` and the held stages' term (each stage "
             "held until a flat completes the defect mask keeps its sums and frames, `preflight.held_stages`) to "
             "the cached rows measured 2026-11-29 11:52-11:54 (the libraries' share 242 MiB then) and those "
             "below (170 MiB): within 8 % in both states, `MASKED_BYTES_PER_PIXEL` (frames folded against "
             "the defect mask, large frames) to the photon_transfer at 4096x3072 row, so that row's ratio is a "
             "fit, not a check. "
             "The disk estimate includes the first dark stage's frames "
             "beyond 256 MiB, held in a temporary file only while that stage is masked (gone at the end: "
             "photon_transfer at 4096x3072 holds 512 MiB there).", "",
             "| scan | peak MiB | estimate MiB | estimate / peak | disk MiB | disk estimate MiB | run s | measured "
             "| machine |", "|---|---:|---:|---:|---:|---:|---:|---|---|"]
    worst = 0.0
    for name, r, mem, disk in rows:
        if not r or "error" in r:
            why = (r or {}).get("error", "not measured in this run")
            est = f"{mem / 2**20:.0f}" if mem else ""
            lines.append(f"| {name} | {why} | {est} | | | | | | |")
            continue
        ratio = mem / r["hwm"]
        worst = max(worst, abs(ratio - 1))
        lines.append(f"| {name} | {r['hwm'] / 2**20:.0f} | {mem / 2**20:.0f} | {ratio:.2f} | "
                     f"{r['disk'] / 2**20:.1f} | {disk / 2**20:.1f} | {r['seconds']:.0f} | "
                     f"{r.get('when', 'fit')}{_exit(r)} | {r['load']} |")
    lines += ["", f"Largest memory error: {worst:.0%} (target {WITHIN:.0%}). Written {time.strftime('%Y-%m-%d')}; "
                  f"1 GiB = {gib} bytes.", ""]
    return publish("estimates", lines)


if __name__ == "__main__":
    raise SystemExit(main())
