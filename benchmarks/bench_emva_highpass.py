"""``ares emva``'s per-step EMVA 4.0 spatial variances: numpy's exact box sums against the
numba streaming kernel (``ares.analysis.kernels.highpass``, issue 40), in one run; writes
benchmarks/emva_highpass.md.

    python benchmarks/bench_emva_highpass.py [--tile 2] [--rounds 3]

On the EMVA 1288 reference CCD set (640x480, 300 images; read from ../shared/data, not
copied) and on the same images tiled ``--tile`` x ``--tile`` (written as 16-bit TIFFs to a
temporary folder, deleted after; a larger sensor with real images, for timing only):

1. the whole ``ares emva`` command, numpy paths (numba not loaded) against the kernels
   (numba loaded), ``--rounds`` interleaved rounds, medians: wall, CPU, peak RSS;
2. the analysis on one thread (``bench_twelve_mp``'s split of its CPU time): the CPU of
   ``emva_spatial.split`` over every step and stack, and of the whole analysis (numba's
   load included), each path, medians of the same rounds.

Ratios are within this run; each row gives the machine load.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from machine_load import Window  # (beside this script)
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DESC = ROOT.parent / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / "EMVA1288_Data.txt"
# ares emva with the numba switch forced: argv[1] = NUMBA_PAYS_PIXELS (0: kernels, inf: numpy)
FORCED = ("import sys\nfrom ares.commands import emva\nemva.NUMBA_PAYS_PIXELS = float(sys.argv.pop(1))\n"
          "from ares.cli import console\nsys.argv[0] = 'ares'\nconsole()")


def tiled(src: Path, dst: Path, k: int) -> Path:
    """The set of ``src`` with every image tiled k x k, as 16-bit TIFFs in ``dst``."""
    import numpy as np
    from PIL import Image

    (dst / "img").mkdir(parents=True)
    out = []
    for ln in src.read_text().splitlines():
        if ln.startswith("n "):
            _, b, w, h = ln.split()
            ln = f"n {b} {k * int(w)} {k * int(h)}"
        elif ln.startswith("i "):
            p = ln[2:].strip().replace("\\", "/")
            a = np.asarray(Image.open(src.parent / p), np.uint16)
            name = "img/" + Path(p).stem + ".tif"
            Image.fromarray(np.tile(a, (k, k))).save(dst / name)
            ln = "i " + name
        out.append(ln)
    d = dst / "EMVA1288_Data.txt"
    d.write_text("\n".join(out) + "\n")
    return d


def shares(desc: Path, kernels: bool) -> dict:
    """bench_twelve_mp's one-thread CPU split of the analysis, numpy paths or kernels."""
    sys.path.insert(0, str(HERE))
    import bench_twelve_mp as b

    code = b.SHARES.replace("with jit.avoided():  # as ares emva",
                            "import contextlib\nwith (contextlib.nullcontext() if sys.argv[2] == '1' else jit.avoided()):")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-c", code, str(desc), "1" if kernels else "0"], capture_output=True,
                       text=True, cwd=ROOT, env=env, timeout=3600)
    if p.returncode:
        raise SystemExit(p.stderr[-2000:])
    s = json.loads(p.stdout.strip().splitlines()[-1])
    return {"split": next(v for k, v in s.items() if k.startswith("spatial")), "total": s["total"]}


def med(xs):
    return sorted(xs)[len(xs) // 2]


def measure(desc: Path, rounds: int) -> tuple[dict, str]:
    import bench_peer as bp

    got = {m: {"wall": [], "cpu": [], "rss": [], "split": [], "analysis": []} for m in ("numpy", "kernels")}
    py = sys.executable
    bp.measured([py, FORCED, "0", "emva", str(desc)])  # numba's cache loaded, the files in the page cache
    with Window() as w:
        for r in range(rounds):
            for m in (("numpy", "kernels") if r % 2 == 0 else ("kernels", "numpy")):
                wall, cpu, rss, _ = bp.measured([py, FORCED, "0" if m == "kernels" else "inf", "emva", str(desc)])
                sh = shares(desc, m == "kernels")
                for k, v in (("wall", wall), ("cpu", cpu), ("rss", rss), ("split", sh["split"]),
                             ("analysis", sh["total"])):
                    got[m][k].append(v)
    return {m: {k: med(v) for k, v in d.items()} for m, d in got.items()}, w.cell()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--tile", type=int, default=2, help="also the reference images tiled k x k (0: not)")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    if not DESC.exists():
        return publish("emva_highpass", ["## `ares emva`'s spatial variances: numpy against the kernel", "",
                                         f"{DESC} is not there: not measured."])
    lines = ["## `ares emva`'s per-step spatial variances: numpy against the numba kernel (`bench_emva_highpass.py`)",
             "", f"Medians of {args.rounds} interleaved rounds. `split`: the CPU of `emva_spatial.split` over every "
             "two-image step and both stacks (the 4.0 high-pass, Section 8.1), the analysis on one thread "
             "(`bench_twelve_mp`'s harness; numba's load counted in the kernels' analysis); `ares emva`: the whole "
             "command (2 threads).", "",
             "| set | path | split CPU s | analysis CPU s | `ares emva` wall s | CPU s | peak RSS MiB | machine load |",
             "|---|---|---:|---:|---:|---:|---:|---|"]
    with tempfile.TemporaryDirectory() as td:
        sets = [("reference CCD 640x480, 300 images", DESC)]
        if args.tile > 1:
            sets.append((f"reference CCD tiled {args.tile}x{args.tile} ({640 * args.tile}x{480 * args.tile})",
                         tiled(DESC, Path(td) / "set", args.tile)))
        for name, desc in sets:
            got, cell = measure(desc, args.rounds)
            n, k = got["numpy"], got["kernels"]
            for m, d in got.items():
                lines.append(f"| {name} | {m} | {d['split']:.2f} | {d['analysis']:.2f} | {d['wall']:.2f} | "
                             f"{d['cpu']:.2f} | {d['rss']:.0f} | {cell} |")
            lines.append(f"| {name} | numpy / kernels | **{n['split'] / k['split']:.1f}x** | "
                         f"{n['analysis'] / k['analysis']:.2f}x | {n['wall'] / k['wall']:.2f}x | "
                         f"{n['cpu'] / k['cpu']:.2f}x | {k['rss'] - n['rss']:+.0f} | |")
            print(lines[-3:], flush=True)
    return publish("emva_highpass", lines + ["", "`ares emva` loads the kernels for a set of more than "
                                             "`emva.NUMBA_PAYS_PIXELS` image pixels, else takes the numpy paths. "
                                             "Both harnesses run with one BLAS thread, as `ares emva` does: with "
                                             "OpenBLAS's default threads the numpy path's `np.dot` spins them and "
                                             "the one-thread split had measured 11.6 s of CPU for the tiled set's "
                                             "analysis instead of 3.9 s (the 59 % share of "
                                             "`twelve_mp_peer_2048x1536.md` was measured so)."])


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    raise SystemExit(main())
