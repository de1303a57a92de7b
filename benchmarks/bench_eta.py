"""Time Remaining on the shipped simulator scans (headless, both cores): how far the time
shown at the second frame of every stage after the first is from the time the scan really
took from there to its last stage's commit (the ``Ending`` event; the reports after it are
not in the estimate). make run's scan is run most, and shown stage by stage. Writes
benchmarks/eta.md.

Each run records what the runner told its ``Eta`` (event times, stack costs, the
simulator's seconds, commit times). The same recordings are then replayed through the
estimator with parts of its input withheld -- the baselines of the same run:

* no stack costs and no simulator seconds (every lit frame charged at the latest rate:
  what the estimator did before ``sim/cost.py``);
* no commit times (the wait for the last stage's analysis not charged).

    python benchmarks/bench_eta.py [--runs 8] [--others 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ares.protocol import load_scan  # noqa: E402
from ares.scan import events as ev  # noqa: E402
from ares.scan import runner as R  # noqa: E402
from ares.scan.eta import Eta  # noqa: E402
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

CALLS = ("stage_started", "frame", "one_off", "stage_finished", "end_work")


SCANS = ("photon_transfer", "ptc_exposure", "dark_current", "temperature", "gain", "lag", "bias_sweep_2d",
         "adc_linearity", "emva_4")


PACED = ("photon_transfer", "ptc_exposure", "gain", "bias_sweep_2d")  # (dark_current, temperature: a minute each)


def paced_copy(name: str, where: Path) -> Path:
    """``scans/NAME.xml`` on a copy of the simulator system with ``paced="true"``."""
    import shutil

    for sub in ("scans", "protocols"):
        shutil.copytree(ROOT / sub, where / sub, dirs_exist_ok=True)
    system = where / "protocols" / "sim_sensor.xml"
    text = system.read_text()
    assert '<simulator seed="1">' in text
    system.write_text(text.replace('<simulator seed="1">', '<simulator seed="1" paced="true">'))
    return where / "scans" / f"{name}.xml"


def record(name: str = "photon_transfer", paced: bool = False) -> tuple[list, float]:
    """One run of ``scans/NAME.xml`` (``paced``: its frames at the sensor's pace): the Eta
    calls, and when its last stage was committed."""
    calls: list = []

    class Recorded(Eta):
        def __init__(self, *a, **k):
            calls.append(("init", a, k))
            super().__init__(*a, **k)

    for method in CALLS:
        def call(self, *a, _name=method, **k):
            calls.append((_name, a, k))
            return getattr(Eta, _name)(self, *a, **k)
        setattr(Recorded, method, call)
    keep, R.Eta = R.Eta, Recorded
    ended: list[float] = []
    try:
        with tempfile.TemporaryDirectory() as d:
            scan = load_scan(paced_copy(name, Path(d)) if paced else ROOT / "scans" / f"{name}.xml")
            r = R.Runner(scan, out_dir=Path(d) / "run", seed=1)
            r.add_listener(lambda e: isinstance(e, ev.Ending) and ended.append(time.monotonic() - r._t0))
            assert r.run().status == "done"
    finally:
        R.Eta = keep
    return calls, ended[0]


def replay(calls: list, t_end: float, costs: bool = True, commits: bool = True) -> list[float]:
    """Relative error of the time shown at the second frame of each stage after the first."""
    eta, stage, n, errors = None, 0, 0, []
    for name, a, k in calls:
        if name == "init":
            k = dict(k)
            if not costs:
                k["stacks"] = [(*s[:3], 1.0) for s in k["stacks"]]
            eta = Eta(*a, **k)
            continue
        if name == "frame" and not costs:
            a = a[:1]
        if name == "end_work" and not commits:
            continue
        getattr(eta, name)(*a, **k)
        if name == "stage_started":
            n = 0
        elif name == "stage_finished":
            stage, n = stage + 1, 0
        elif name == "frame":
            n += 1
            if n == 2 and stage >= 1:
                errors.append(eta.remaining(a[0]) / (t_end - a[0]) - 1)
    return errors


def seconds_off(calls: list, t_end: float) -> float:
    """The largest difference, in seconds, between the time shown (as fed) and the time left."""
    left = [t_end - a[0] for name, a, _ in calls if name == "frame"]
    return max(abs(e) * t for e, t in zip(replay(calls, t_end), _checked(calls, left)))


def _checked(calls: list, left: list[float]) -> list[float]:
    """The time left at the frames ``replay`` checks (the second of each stage after the first)."""
    out, stage, n, k = [], 0, 0, -1
    for name, a, _ in calls:
        if name == "stage_started":
            n = 0
        elif name == "stage_finished":
            stage, n = stage + 1, 0
        elif name == "frame":
            k, n = k + 1, n + 1
            if n == 2 and stage >= 1:
                out.append(left[k])
    return out


def unit_costs(calls: list) -> dict[float, float]:
    """The simulator's ms a frame per unit of modelled cost, median over the stacks of each cost."""
    stacks = next(k for name, _, k in calls if name == "init")["stacks"]
    out: dict[float, list[float]] = {}
    k, first, last, n = -1, None, None, 0
    for name, a, _ in [*calls, ("stage_started", (), {})]:
        if name == "stage_started":
            if k >= 0 and n > 1 and first is not None and last is not None:
                w = round(stacks[k][3], 2)
                out.setdefault(w, []).append(1000 * (last - first) / (n - 1) / w)
            k, first, last, n = k + 1, None, None, 0
        elif name == "frame" and len(a) > 1 and a[1] is not None:
            first = a[1] if first is None else first
            last, n = a[1], n + 1
    return {w: statistics.median(v) for w, v in out.items()}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=8, help="runs of make run's scan")
    ap.add_argument("--others", type=int, default=3, help="runs of each other scan")
    ap.add_argument("--paced", type=int, default=2, help="runs of each scan in PACED with the simulator paced")
    args = ap.parse_args()
    recorded = {name: [record(name) for _ in range(args.runs if name == "photon_transfer" else args.others)]
                for name in SCANS}
    paced = {name: [record(name, paced=True) for _ in range(args.paced)] for name in PACED}
    variants = [("as fed", {}), ("without costs", {"costs": False}), ("without commit times", {"commits": False})]
    lines = ["## Time Remaining (`scan/eta.py`) on the shipped scans", "",
             f"Headless runs of each simulator scan in `scans/` ({args.runs} of make run's, {args.others} of the "
             "others; both cores: the stage analysis runs beside the next stage's frames). Error of the time "
             "shown at the second frame of each stage after the first against the time the scan really took "
             "from there to its last commit. Baselines of the same runs: the recordings replayed without the "
             "stack costs and the simulator's seconds (every stack to come charged at the latest rate), and "
             "without the commit times.", "",
             "| scan | stages | scan s | mean abs error | within 10 % | largest error s | without costs | "
             "without commit times |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    per_scan = {}
    for name, runs in recorded.items():
        cells = []
        for label, kw in variants:
            errs = [replay(c, t, **kw) for c, t in runs]
            per_scan[(name, label)] = errs
            flat = [abs(e) for run in errs for e in run]
            cells.append((statistics.fmean(flat), sum(e <= 0.10 for e in flat), len(flat)))
        (m, k, n), (mb, _, _), (mc, _, _) = cells
        length = statistics.median(t for _, t in runs)
        worst = statistics.median(seconds_off(c, t) for c, t in runs)
        lines.append(f"| {name} | {len(per_scan[(name, 'as fed')][0]) + 1} | {length:.1f} | {100 * m:.1f} % | "
                     f"{k}/{n} | {worst:.2f} | {100 * mb:.1f} % | {100 * mc:.1f} % |")
    errs, base = per_scan[("photon_transfer", "as fed")], per_scan[("photon_transfer", "without costs")]
    lines += ["", "make run's scan, mean error (and its spread over runs) at each stage (numbered from 1, the dark "
              "stage), as fed / without costs:", "",
              "| stage | " + " | ".join(str(i + 2) for i in range(len(errs[0]))) + " |",
              "|---|" + "---:|" * len(errs[0])]
    for label, e in (("as fed", errs), ("no costs", base)):
        cells = [f"{100 * statistics.fmean(r[i] for r in e):+.0f}±{100 * statistics.pstdev([r[i] for r in e]):.0f}"
                 for i in range(len(e[0]))]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    per_unit: dict[float, list[float]] = {}
    for c, _ in recorded["photon_transfer"]:
        for w, v in unit_costs(c).items():
            per_unit.setdefault(w, []).append(v)
    low = range(0, 11)  # stages 2-12: the exact-Poisson low-light stages, the 14 brighter ones still to come
    early = {label: statistics.fmean(r[i] for r in e for i in low) for label, e in (("fed", errs), ("none", base))}
    lines += ["", "Without the costs, make run's 14 brighter stages are charged at the 11 low-light stages' rate; "
              "with them, at the rate the simulator's path costs (`sim/cost.py`: exact Poisson 1.5x a Gaussian "
              f"draw). Stages 2-12 in this run: {100 * early['fed']:+.0f} % as fed, {100 * early['none']:+.0f} % "
              "without costs (mean signed error). The simulator's own milliseconds a frame per unit of modelled "
              "cost, median of each run, by stack cost: "
              + "; ".join(f"{w:g}: " + ", ".join(f"{v:.2f}" for v in vs) for w, vs in sorted(per_unit.items()))
              + ". The constants were measured on one machine; where the paths' relative costs differ from them, "
              "nothing in the scan shows it until the first stage of the other path is timed. The scatter that is left is the VM's: stage times vary by 10 % or more in "
              "bursts that no estimate made before them can see. The largest errors are in a scan's first stages "
              "after the first (the first lit stage after an ADC ramp, lag's six stages: its whole scan lasts half "
              "a second) and in the last ones, where little time is left. Largest error: median over the runs of "
              "the largest difference between the time shown and the time left."]
    lines += ["", f"### At a sensor's pace ({args.paced} runs each)", "",
              "The same scans on the simulator with `paced=\"true\"` (`ares/protocol/FORMAT.md`): each frame "
              "comes no sooner than its exposure + readout after the one before, as from a streaming sensor, and "
              "the time remaining plans each stack as a real sensor's (exposure + readout, plus the time beyond "
              "it that the run measures). What a lab engineer sees on the bench.", "",
              "| scan | stages | scan s | mean abs error | within 10 % | largest error s |", "|---|---:|---:|---:|---:|---:|"]
    for name, runs in paced.items():
        flat = [abs(e) for c, t in runs for e in replay(c, t)]
        lines.append(f"| {name} | {len(replay(*runs[0])) + 1} | {statistics.median(t for _, t in runs):.1f} | "
                     f"{100 * statistics.fmean(flat):.1f} % | {sum(e <= 0.10 for e in flat)}/{len(flat)} | "
                     f"{statistics.median(seconds_off(c, t) for c, t in runs):.2f} |")
    return publish("eta", lines)


if __name__ == "__main__":
    sys.exit(main())
