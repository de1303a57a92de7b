"""The shipped simulator's main job at few and many frames (issue 48): ``ares run
scans/photon_transfer.xml --frames F --seed S`` for F in 2, 4, 8, 16, 64 and 10 seeds.
Truth (the simulator's sensor): K = 0.28 DN/e-, full well 12 000 e-. Pass: K within 3 SE of
0.28, and the full well within 3 % of 12 000 e- or "not available" with a reason.

Each run's ``ptc.csv`` is kept (``--keep DIR``) so that ``tests/test_ptc_issue48.py`` can
replay the tables. The table below is Markdown for ``benchmarks/ptc_corpus.md``.

    python benchmarks/bench_ptc_sim.py [--frames 2,4,8,16,64] [--seeds 10] [--keep DIR]
    python benchmarks/bench_ptc_sim.py --truth [--frames 2,64]   # K also against the PTC truth

``--truth`` prints the PTC truth's factors per run too (gain map, lag, INL bow); its table is
``benchmarks/ptc_sim.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
K_TRUE, FW_TRUE = 0.28, 12000.0


def run(frames: int, seed: int, out: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-m", "ares.cli", "run", str(ROOT / "scans/photon_transfer.xml"), "--frames",
                        str(frames), "--seed", str(seed), "--quiet", "--json", "--out", str(out)],
                       capture_output=True, text=True, env=env)
    d = json.loads(p.stdout)
    return d


def judge(ptc: dict) -> tuple[bool, bool, str]:
    k, fw = ptc["gain_dn_per_e"], ptc["full_well_e"]
    k_ok = k["verdict"] == "ok" and k["se"] and abs(k["value"] - K_TRUE) <= 3 * k["se"]
    if fw["verdict"] == "ok":
        fw_ok = abs(fw["value"] - FW_TRUE) <= 0.03 * FW_TRUE
        fw_s = f"{fw['value']:.0f} ± {fw['se']:.0f}"
    else:
        fw_ok = fw["verdict"] == "not available" and bool(fw.get("note"))
        fw_s = f"{fw['verdict']}: {fw.get('note', '')[:50]}"
    ks = f"{k['value']:.5f} ± {k['se']:.5f}" if k["value"] is not None else f"n/a ({k.get('note', '')[:40]})"
    return bool(k_ok), bool(fw_ok), f"{ks} | {fw_s}"


def replay(folder: Path) -> None:
    """The same judgement on kept ``ptc.csv`` tables (the run's own analysis, redone from
    its table: ``test_scan_truth`` checks the two agree)."""
    sys.path.insert(0, str(ROOT))
    from ares.commands.ptc import analyse_table

    print("| frames | seed | K (DN/e-) | full well (e-) | K within 3 SE | full well within 3 % or n/a |")
    print("|---:|---:|---|---|---|---|")
    tot = {}
    files = sorted(folder.glob("frames_*_seed_*.csv"), key=lambda p: tuple(int(x) for x in p.stem.split("_")[1::2]))
    for f in files:
        fr, sd = (int(x) for x in f.stem.split("_")[1::2])
        _, d, _ = analyse_table(f)
        k_ok, fw_ok, txt = judge(d)
        t = tot.setdefault(fr, [0, 0, 0])
        t[0] += k_ok
        t[1] += fw_ok
        t[2] += 1
        print(f"| {fr} | {sd} | {txt} | {'yes' if k_ok else 'NO'} | {'yes' if fw_ok else 'NO'} |")
    print()
    print("| frames | K within 3 SE | full well within 3 % or n/a with reason |")
    print("|---:|---:|---:|")
    for fr, (k, w, n) in sorted(tot.items()):
        print(f"| {fr} | {k}/{n} | {w}/{n} |")


class _Tmp:
    """The ``mktemp`` of pytest's tmp_path_factory, for ``test_scan_truth._run``."""

    def __init__(self, root: Path):
        self.root, self.n = root, 0

    def mktemp(self, name: str) -> Path:
        self.n += 1
        p = self.root / f"{name}{self.n}"
        p.mkdir()
        return p


def with_truth(frames_list, seeds: int) -> None:
    """The same runs in-process (``test_scan_truth._run``), K judged against both the nominal
    0.28 and the PTC truth of the simulated sensor (``test_scan_truth._ptc_k``: realized gain
    map, lag, INL bow -- what ``tests/test_ptc_study.py::test_simulator_main_job`` asserts),
    the full well against ``_full_well_e``."""
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "tests"))
    from test_scan_truth import _full_well_e, _ptc_k, _ptc_k_factors, _run, _truth

    print("| frames | seed | K (DN/e-) | PTC truth K | (K - 0.28) / SE | (K - truth) / SE | mean gain / G | gain map "
          "| lag | INL | full well (e-) | K within 3 SE of 0.28 | K within 3 SE of the PTC truth "
          "| full well within 3 % of its truth or n/a |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|")
    tot = {}
    for f in frames_list:
        for sd in range(1, seeds + 1):
            with tempfile.TemporaryDirectory() as d:
                scan, bench, res, stages = _run("photon_transfer", _Tmp(Path(d)), frames=f, seed=sd)
                ptc = res["ptc"]
                mid = next(s_ for s_ in stages if s_["name"] == res["decomposition"]["stage"])
                t = _truth(scan, bench, mid["settings"])
                k_true = _ptc_k(t, mid["views"]["full"]["level"]["n_frames"])
                fac = _ptc_k_factors(t, mid["views"]["full"]["level"]["n_frames"])
                k_nom, _, txt = judge(ptc)
                k, fw = ptc["gain_dn_per_e"], ptc["full_well_e"]
                k_ok = k["verdict"] == "ok" and abs(k["value"] - k_true) <= 3 * k["se"]
                fw_true = _full_well_e(t, k_true)
                fw_ok = (abs(fw["value"] - fw_true) <= 0.03 * fw_true if fw["verdict"] == "ok"
                         else fw["verdict"] == "not available" and bool(fw.get("note")))
            ks, fws = txt.split(" | ")
            tt = tot.setdefault(f, [0, 0, 0, 0])
            tt[0] += k_nom
            tt[1] += k_ok
            tt[2] += fw_ok
            tt[3] += 1
            z0 = (k["value"] - K_TRUE) / k["se"] if k["se"] else float("nan")
            zt = (k["value"] - k_true) / k["se"] if k["se"] else float("nan")
            fs = " | ".join(f"{fac[n]:.5f}" for n in ("mean_gain", "gain_map", "lag", "inl"))
            print(f"| {f} | {sd} | {ks} | {k_true:.5f} | {z0:+.1f} | {zt:+.1f} | {fs} | {fws} | {'yes' if k_nom else 'NO'} | {'yes' if k_ok else 'NO'} "
                  f"| {'yes' if fw_ok else 'NO'} |", flush=True)
    print()
    print("| frames | K within 3 SE of 0.28 | K within 3 SE of the PTC truth | full well within 3 % or n/a with reason |")
    print("|---:|---:|---:|---:|")
    for f, (a, b, c, n) in sorted(tot.items()):
        print(f"| {f} | {a}/{n} | {b}/{n} | {c}/{n} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", default="2,4,8,16,64")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--keep", default=None, help="folder to keep each run's ptc.csv in (frames_F_seed_S.csv)")
    ap.add_argument("--replay", default=None, help="judge the kept tables of a --keep folder with today's "
                                                   "analysis (ares ptc on each ptc.csv), without running the scans")
    ap.add_argument("--truth", action="store_true", help="run in-process and judge K also against the simulated "
                                                          "sensor's PTC truth (test_scan_truth._ptc_k)")
    a = ap.parse_args()
    if a.truth:
        return with_truth([int(x) for x in a.frames.split(",")], a.seeds)
    if a.replay:
        return replay(Path(a.replay))
    keep = Path(a.keep) if a.keep else None
    if keep:
        keep.mkdir(parents=True, exist_ok=True)
    print("| frames | seed | K (DN/e-) | full well (e-) | K within 3 SE | full well within 3 % or n/a | s |")
    print("|---:|---:|---|---|---|---|---:|")
    tot = {}
    for f in [int(x) for x in a.frames.split(",")]:
        for s in range(1, a.seeds + 1):
            with tempfile.TemporaryDirectory() as d:
                t0 = time.perf_counter()
                out = run(f, s, Path(d) / "run")
                dt = time.perf_counter() - t0
                rd = Path(out["run_dir"])
                if keep:
                    shutil.copy(rd / "ptc.csv", keep / f"frames_{f}_seed_{s}.csv")
                k_ok, fw_ok, txt = judge(out["scan_results"]["ptc"])
            t = tot.setdefault(f, [0, 0, 0])
            t[0] += k_ok
            t[1] += fw_ok
            t[2] += 1
            print(f"| {f} | {s} | {txt} | {'yes' if k_ok else 'NO'} | {'yes' if fw_ok else 'NO'} | {dt:.0f} |",
                  flush=True)
    print()
    print("| frames | K within 3 SE | full well within 3 % or n/a with reason |")
    print("|---:|---:|---:|")
    for f, (k, w, n) in tot.items():
        print(f"| {f} | {k}/{n} | {w}/{n} |")


if __name__ == "__main__":
    main()
