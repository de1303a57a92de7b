"""``ares bench SCAN``: run time against accuracy, to choose frames per stage and levels.

On the simulator: every setting of the knobs (frames per stage, number and spacing of the
sweep's levels, sensor size, shot-noise fidelity) is run over several seeds on the scan's
simulated sensor (defect-free, so the truth is exact); per setting the wall time
(acquisition and analysis apart) and each key figure's bias and spread against the truth,
next to the SE the analysis reported. On a real bench (``--pilot``, or a system that is
not a simulator) one pilot run is made and its SEs and times are carried to other frame
counts. Writes ``bench.csv`` (per setting), ``bench_runs.csv`` (per run), ``bench.png`` and
``bench.pdf`` (error vs time, Pareto front, recommendation) and ``bench.json``.
"""

from __future__ import annotations

import csv
import json
import sys
import time
from pathlib import Path

from ares.errors import InputError

NAME = "bench"
HELP = "run time against accuracy: sweep frames/levels/size/fidelity on the simulator, recommend a setting"


def _ints(text: str) -> tuple[int, ...]:
    try:
        v = tuple(int(x) for x in text.split(","))
    except ValueError:
        raise InputError(f"expected comma-separated integers, got '{text}'") from None
    return v


def _words(text: str) -> tuple[str, ...]:
    return tuple(x.strip() for x in text.split(",") if x.strip())


def add_arguments(parser) -> None:
    parser.add_argument("scan", metavar="SCAN", help="scan XML with a light or exposure sweep")
    parser.add_argument("--quick", action="store_true",
                        help="a small grid on a 64x64 cut of the sensor (under a minute; its recommendation is for 64x64)")
    parser.add_argument("--seeds", type=int, help="seeds per setting (default 3, --quick 2)")
    parser.add_argument("--frames", type=_ints, metavar="N,N", help="frames per stage (default 2,4,8,16)")
    parser.add_argument("--levels", type=_ints, metavar="N,N", help="sweep points (default 9,17,25)")
    parser.add_argument("--spacing", type=_words, metavar="log,linear", help="sweep spacing (default log,linear)")
    parser.add_argument("--size", type=_ints, metavar="N,N",
                        help="square sensor sizes rows = cols (default: the scan's own sensor; --quick 64)")
    parser.add_argument("--fidelity", type=_words, metavar="auto,exact",
                        help="simulator shot noise: auto, exact, gaussian (default auto,exact)")
    parser.add_argument("--target", action="append", default=[], metavar="FIGURE=PCT",
                        help="relative error wanted, e.g. gain_ptc=0.5 (percent); figures: gain_ptc, "
                             "gain_one_level, read_noise, full_well (default gain_ptc=0.5 read_noise=2)")
    parser.add_argument("--pilot", action="store_true",
                        help="no truth: one pilot run, its SEs and times carried to other frame counts "
                             "(what a real bench can do)")
    parser.add_argument("--out", metavar="DIR", help="output folder (default runs/bench_<scan>_<time>)")
    parser.add_argument("--quiet", "-q", action="store_true", help="no progress bar")


def _targets(items: list[str]) -> dict[str, float]:
    from ares.tuning.measure import FIGURES

    out = {}
    for it in items or ["gain_ptc=0.5", "read_noise=2"]:
        k, _, v = it.partition("=")
        if k not in FIGURES:
            raise InputError(f"--target {it}: unknown figure '{k}' (known: {', '.join(FIGURES)})")
        try:
            out[k] = float(v.rstrip("%")) / 100
        except ValueError:
            raise InputError(f"--target {it}: expected FIGURE=PERCENT, e.g. gain_ptc=0.5") from None
    return out


class _Bar:
    def __init__(self, total: int, quiet: bool):
        self.total, self.done, self.t0 = total, 0, time.monotonic()
        self.quiet = quiet

    def step(self, label: str) -> None:
        self.done += 1
        if self.quiet:
            return
        n = int(24 * self.done / self.total)
        left = (time.monotonic() - self.t0) / self.done * (self.total - self.done)
        sys.stderr.write(f"\r[{'#' * n}{'.' * (24 - n)}] {self.done}/{self.total} {label:<28.28} "
                         f"{left:5.0f} s left")
        if self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def _grid(args, scan) -> dict:
    from ares.tuning.grid import FULL, QUICK, own_size

    g = dict(QUICK if args.quick else FULL)
    for k in ("frames", "levels", "spacing", "size", "fidelity"):
        if getattr(args, k):
            g[k] = getattr(args, k)
    if g["size"] is None:
        g["size"] = (own_size(scan),)
    if min(g["frames"]) < 2:
        raise InputError("--frames: every stage needs at least 2 frames")
    if min(g["levels"]) < 3:
        raise InputError("--levels: a photon-transfer fit needs at least 3 levels")
    return g


def run(args) -> int:
    from ares.protocol import load_scan
    from ares.tuning import grid as gridmod
    from ares.tuning.measure import run_once
    from ares.tuning.plot import plot
    from ares.tuning.tradeoff import predict_from_pilot, recommend, summarize

    scan = load_scan(args.scan)
    targets = _targets(args.target)
    pilot = args.pilot or scan.system.simulator is None
    out = Path(args.out) if args.out else Path("runs") / f"bench_{scan.name}_{time.strftime('%Y%m%d-%H%M%S')}"
    gridmod.sweep_axis(scan)  # a scan it cannot benchmark (no 1-D level sweep) is refused before any run
    g = _grid(args, scan)
    out.mkdir(parents=True, exist_ok=True)
    rows, labels, summaries = [], [], []
    if pilot:
        n0 = min(g["frames"]) if args.frames else scan.frames
        bar = _Bar(1, args.quiet)
        bench = None
        if scan.system.simulator is None:
            from ares.rig.factory import build_bench

            bench = build_bench(scan.system)
        try:
            r = run_once(scan, seed=scan.system.simulator.seed if scan.system.simulator else 0, frames=n0, bench=bench)
        finally:
            if bench is not None:
                bench.close()
        bar.step("pilot")
        for f in r["figures"].values():
            f["truth"] = None  # a real bench has none: SEs only
        rows.append(dict(r, setting=f"pilot {n0}f", seed=None))
        n_stages = max(1, round(r["frames"] / n0))
        frames = sorted(set(g["frames"]) | {n0})
        summaries = predict_from_pilot(r, n0, frames, n_stages)
        labels = [f"{n}f{'' if n == n0 else ' (predicted)'}" for n in frames]
    else:
        sets = gridmod.settings(g)
        seeds = args.seeds or (2 if args.quick else 3)
        bar = _Bar(len(sets) * seeds, args.quiet)
        run_once(gridmod.scan_for(scan, sets[0]), 0, frames=2)  # warm-up: imports and caches out of the timings
        for s in sets:
            sc = gridmod.scan_for(scan, s)
            runs = []
            for seed in range(seeds):
                r = run_once(sc, seed, frames=s.frames)
                runs.append(r)
                rows.append(dict(r, setting=s.label(), seed=seed))
                bar.step(s.label())
            labels.append(s.label())
            summaries.append(summarize(runs))
    own = gridmod.own_size(scan)
    best, sentence = recommend(labels, summaries, targets)
    _write(out, labels, summaries, rows, best, sentence, targets, pilot)
    plot(labels, summaries, best, out / "bench.png", out / "bench.pdf",
         title=f"ares bench {scan.name}: {'standard error' if pilot else 'error vs truth'} against time "
               f"({'pilot ' + labels[0] if pilot else str(len(labels)) + ' settings'})", truth=not pilot)
    print(f"ares bench {scan.name}: {len(labels)} setting(s), "
          f"{'one pilot run (SEs predicted for other frame counts)' if pilot else f'{len(rows)} runs'}")
    print(f"recommended: {sentence}")
    if not pilot and own not in {tuple(s.rows_cols) for s in gridmod.settings(g)}:
        print(f"note: measured on {', '.join(sorted({s.label().split()[0] for s in gridmod.settings(g)}))} cuts of "
              f"the sensor, not on the scan's own {own[1]}x{own[0]}: run without --quick/--size for its own size")
    print(f"table: {out / 'bench.csv'}\nplot: {out / 'bench.png'} and {out / 'bench.pdf'}")
    return 0


def _write(out: Path, labels, summaries, rows, best, sentence, targets, pilot) -> None:
    from ares.tuning.measure import FIGURES
    from ares.tuning.tradeoff import accuracy, pareto

    fronts = {}
    for key in FIGURES:
        idx = [i for i, s in enumerate(summaries) if accuracy(s, key) is not None]
        fronts[key] = {idx[j] for j in pareto([(summaries[i]["time_s"], accuracy(summaries[i], key)) for i in idx])}
    with open(out / "bench.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        head = ["setting", "seeds", "frames", "acquisition_s", "analysis_s", "time_s"]
        for key in FIGURES:
            head += [f"{key}_{c}" for c in ("bias_pct", "spread_pct", "rms_pct", "se_pct", "pareto")]
        w.writerow(head + ["recommended"])
        for i, (label, s) in enumerate(zip(labels, summaries)):
            row = [label, s["seeds"], s["frames"], f"{s['acquisition_s']:.4f}", f"{s['analysis_s']:.4f}",
                   f"{s['time_s']:.4f}"]
            for key in FIGURES:
                f = s["figures"][key]
                row += [_pct(f.get("bias_rel")), _pct(f.get("spread_rel")), _pct(f.get("rms_rel")),
                        _pct(f.get("se_rel")), int(i in fronts[key])]
            w.writerow(row + [int(i == best)])
    with open(out / "bench_runs.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["setting", "seed", "status", "acquisition_s", "analysis_s", "frames"]
                   + [f"{k}_{c}" for k in FIGURES for c in ("value", "se", "truth")])
        for r in rows:
            w.writerow([r["setting"], r["seed"], r["status"], f"{r['acquisition_s']:.4f}", f"{r['analysis_s']:.4f}",
                        r["frames"]] + [r["figures"][k][c] for k in FIGURES for c in ("value", "se", "truth")])
    (out / "bench.json").write_text(json.dumps({
        "mode": "pilot" if pilot else "simulator truth", "targets_rel": targets, "recommended": None if best is None
        else labels[best], "recommendation": sentence, "settings": dict(zip(labels, summaries))}, indent=1,
        default=str))


def _pct(v) -> str:
    return "" if v is None else f"{100 * v:.4f}"
