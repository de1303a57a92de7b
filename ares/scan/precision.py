"""Precision-driven scans (``<precision>``): frames per stage from target standard errors.

The stopping rule decides once, from a pilot, and never looks at the running estimate:

1. Pilot: the whole scan with ``pilot`` frames per stage (n_p). Its frames are kept.
2. Sample size: for each target, an SE from n frames scales as ``1/sqrt(n - 1)`` (every
   figure here is a function of per-pixel temporal variances with n - 1 degrees of freedom
   each -- checked on the simulator, ``tests/test_precision.py``), so

       N - 1 = (n_p - 1) * (SE_pilot / target)^2 * (1 + z * sqrt(2) * cv)^2

   with z the one-sided normal quantile of ``confidence`` and cv the relative spread of an
   estimated SE (``se_cv``; the margin covers the noise of the pilot's SE and of the final
   one). N is the largest over the targets, at most ``budget``.
3. Main run: the scan with N frames per stage, the pilot's frames first (replayed per
   acquisition, in the same order), then N - n_p new ones. Every frame counts once. The
   pilot's frames wait in memory meanwhile: n_p x acquisitions x frame size (VGA, 26
   stages with matched darks, 3 frames: 92 MB).

N depends on the pilot's *spread* (its SEs), not on its estimates; for these figures the
two are nearly independent, so the final estimates carry no selection bias -- shown over
100 seeds in the tests and in ``benchmarks/precision.md``. A stop-when-precise rule on the
running estimate would not be: it stops early on samples that happen to look precise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

from ares.hardware.interfaces import Bench
from ares.results.registry import find_estimate


@dataclass
class TargetPlan:
    quantity: str
    wanted: str  # the target as written
    pilot_value: float | None
    pilot_se: float | None
    frames: int | None  # None: not plannable (why in note)
    note: str = ""


def plan(results: dict, precision, n_pilot: int) -> tuple[int, list[TargetPlan]]:
    """Frames per stage the targets need, from the pilot's scan results (pure)."""
    z = NormalDist().inv_cdf(precision.confidence)
    margin = (1.0 + z * math.sqrt(2.0) * precision.se_cv) ** 2
    rows, need = [], n_pilot
    for t in precision.targets:
        e = find_estimate(results, t.quantity)
        value = e.get("value") if e else None
        se = e.get("se") if e else None
        if value is None or se is None or not (math.isfinite(value) and math.isfinite(se)) or se <= 0:
            why = (e or {}).get("reason") or "the pilot gave no estimate with an SE"
            rows.append(TargetPlan(t.quantity, t.text(), value, se, None, f"not plannable: {why}; full budget"))
            need = precision.budget
            continue
        want = t.wanted(value)
        n = 1 + math.ceil((n_pilot - 1) * (se / want) ** 2 * margin) if want > 0 else precision.budget
        n = max(n, n_pilot)
        rows.append(TargetPlan(t.quantity, t.text(), value, se, n,
                               "" if n <= precision.budget else f"needs {n} frames, above the budget"))
        need = max(need, n)
    return min(need, precision.budget), rows


class _Recorder:
    """Frame source wrapper that keeps every acquisition's frames (pilot run)."""

    def __init__(self, src):
        self.src, self.calls = src, []
        self.name, self.shape, self.bit_depth = src.name, src.shape, src.bit_depth

    def grab(self, n):
        got = []
        self.calls.append(got)
        for f in self.src.grab(n):
            got.append(f)
            yield f

    def reconnect(self):
        self.src.reconnect()


class _Prefixed:
    """Frame source wrapper: acquisition k yields the pilot's frames of acquisition k
    first, then grabs the rest (main run)."""

    def __init__(self, src, calls):
        self.src, self.calls, self.k = src, calls, 0
        self.name, self.shape, self.bit_depth = src.name, src.shape, src.bit_depth
        self.new_frames = 0

    def grab(self, n):
        pre = self.calls[self.k] if self.k < len(self.calls) else []
        self.k += 1
        for i, f in enumerate(pre[:n]):
            yield type(f)(f.data, i, f.timestamp, dict(f.meta, pilot=True))
        rest = n - min(n, len(pre))
        if rest:
            for f in self.src.grab(rest):
                self.new_frames += 1
                yield f

    def reconnect(self):
        self.src.reconnect()


def _with_frames(bench: Bench, frames) -> Bench:
    return Bench(bench.registers, frames, bench.light, bench.chamber, bench.info, [],
                 recovery_clock=bench.recovery_clock, clock=bench.clock)  # (waits on the bench's clock)


class PrecisionRunner:
    """Pilot, plan, main run -- with a ``Runner``'s controls (stop/abort/listeners/reports)
    so the CLI drives it the same way. ``report`` (also ``precision.json`` in the run
    directory) holds the plan and the precision reached."""

    def __init__(self, scan, *, bench=None, out_dir=None, seed=None, argv=None, listeners=(), defer_reports=False,
                 faults=None):
        self.scan, self.out_dir, self.argv = scan, out_dir, argv
        self.seed = scan.system.simulator.seed if seed is None and scan.system.simulator is not None else seed
        self.listeners, self.defer_reports, self.faults = list(listeners), defer_reports, faults
        self._bench, self.current, self.main = bench, None, None
        self._stopped = self._aborted = False
        self.report: dict = {}

    def add_listener(self, fn) -> None:
        self.listeners.append(fn)

    def stop(self) -> None:
        self._stopped = True
        if self.current is not None:
            self.current.stop()

    def abort(self) -> None:
        self._aborted = True
        if self.current is not None:
            self.current.abort()

    def _start(self, runner):
        self.current = runner
        if self._aborted:
            runner.abort()
        elif self._stopped:
            runner.stop()
        return runner.run()

    def run(self):
        from ares.rig.factory import build_bench
        from ares.scan.runner import Runner

        p = self.scan.precision
        bench = self._bench or build_bench(self.scan.system, seed=self.seed, faults=self.faults)
        try:
            rec = _Recorder(bench.frames)
            pilot = self._start(Runner(self.scan, bench=_with_frames(bench, rec), seed=self.seed, frames=p.pilot,
                                       listeners=tuple(self.listeners)))
            if pilot.status != "done":
                self.report = {"status": f"pilot {pilot.status}", "message": pilot.message}
                return pilot
            n, rows = plan(pilot.scan_results, p, p.pilot)
            pre = _Prefixed(bench.frames, rec.calls)
            self.main = Runner(self.scan, bench=_with_frames(bench, pre), out_dir=self.out_dir, seed=self.seed,
                               frames=n, argv=self.argv, listeners=tuple(self.listeners),
                               defer_reports=self.defer_reports)
            outcome = self._start(self.main)
            self.report = reached(outcome.scan_results, p, n, rows)
            self.report.update(pilot_frames=p.pilot, new_frames=pre.new_frames, budget=p.budget,
                               confidence=p.confidence, se_cv=p.se_cv)
            if outcome.run_dir is not None:
                import json

                (outcome.run_dir / "precision.json").write_text(json.dumps(self.report, indent=1))
            return outcome
        finally:
            if self._bench is None:
                bench.close()

    def write_reports(self, helper=None) -> str:
        return self.main.write_reports(helper) if self.main is not None else ""


def reached(results: dict, precision, frames: int, rows: list[TargetPlan]) -> dict:
    """Each target with the SE the run reached and whether it is met."""
    out = []
    for t, r in zip(precision.targets, rows):
        e = find_estimate(results, t.quantity) or {}
        v, se = e.get("value"), e.get("se")
        ok = v is not None and se is not None and math.isfinite(se) and se <= t.wanted(v) * (1 + 1e-12)
        out.append({"quantity": t.quantity, "target": t.text(), "value": v, "se": se,
                    "se_rel": (se / abs(v)) if v and se is not None else None, "met": bool(ok),
                    "pilot_value": r.pilot_value, "pilot_se": r.pilot_se, "frames_planned": r.frames,
                    "note": r.note})
    return {"frames_per_stage": frames, "targets": out, "all_met": all(x["met"] for x in out)}
