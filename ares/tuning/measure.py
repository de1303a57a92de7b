"""One ``ares bench`` run: a scan at one setting and seed on the simulator, its wall time
split into acquisition and analysis, and each key figure's estimate, SE and truth.

The sensor is the scan's simulator without defect pixels: the truths below are then
exact (``SimSensor.truth``), and a figure's error is the estimator's, not a defect's.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

# figure -> (quantity in the scan results, label, unit)
FIGURES = {
    "gain_ptc": ("ptc.gain_dn_per_e", "gain, photon-transfer fit", "DN/e-"),
    "gain_one_level": ("decomposition.G", "gain, one level (decomposition)", "DN/e-"),
    "read_noise": ("ptc.read_noise_e", "read noise", "e-"),
    "full_well": ("ptc.full_well_e", "full well", "e-"),
}


@dataclass
class Timing:
    acquisition_s: float = 0.0
    analysis_s: float = 0.0


class _Clock:
    """Listener: time from a stage's start to its last frame is acquisition; from there to
    the stage's end, and after the last stage, is analysis."""

    def __init__(self):
        self.t = Timing()
        self._mark = None
        self._last_frame = None

    def __call__(self, e) -> None:
        from ares.scan import events as ev

        now = time.perf_counter()
        if isinstance(e, ev.StageStarted):
            self._mark, self._last_frame = now, None
        elif isinstance(e, ev.Progress):
            self._last_frame = now
        elif isinstance(e, ev.StageFinished) and self._mark is not None:
            end = self._last_frame or now
            self.t.acquisition_s += end - self._mark
            self.t.analysis_s += now - end
            self._mark = now
        elif isinstance(e, (ev.Done, ev.Failed)) and self._mark is not None:
            self.t.analysis_s += now - self._mark


def truths(bench) -> dict:
    """The exact values of FIGURES for the bench's (defect-free) simulated sensor at the
    operating point its registers hold, with no light."""
    sensor = bench.info["sensor"]
    s = bench.frames.settings()
    for k in ("test_mode", "streaming", "photon_flux"):
        s.pop(k)
    t = sensor.truth(photon_flux=0.0, **s)
    rows, cols = sensor.shape
    gain = float(t["maps"]["gain_dn_per_e"].mean())
    dark_var = t["realized"]["Pt"] * (1 - 1 / (rows * cols)) + t["Ct"] * (1 - 1 / cols) + t["Rt"] * (1 - 1 / rows)
    return {"gain_ptc": gain, "gain_one_level": gain, "read_noise": math.sqrt(dark_var) / t["G"],
            "full_well": t["full_well_e"]}


def run_once(scan, seed: int, frames: int | None = None, bench=None) -> dict:
    """Run ``scan`` once (no run directory). Returns timing, and per figure the estimate,
    its SE (None when the analysis gave none) and, on the simulator, the truth."""
    from ares.sim.from_system import sim_params
    from ares.scan import Runner
    from ares.results.registry import find_estimate
    from ares.sim import make_sim_bench

    own = bench is None
    if own:
        bench = make_sim_bench(sim_params(scan.system).without_defects(), seed)
    clock = _Clock()
    try:
        t0 = time.perf_counter()
        out = Runner(scan, bench=bench, seed=seed, frames=frames, listeners=(clock,),
                     pipeline=False).run()  # acquisition and analysis timed apart: one thread
        wall = time.perf_counter() - t0
        truth = truths(bench) if "sensor" in bench.info and hasattr(bench.frames, "settings") else {}
    finally:
        if own:
            bench.close()
    figs = {}
    for key, (q, _, _) in FIGURES.items():
        e = find_estimate(out.scan_results, q) or {}
        v, se = e.get("value"), e.get("se")
        ok = v is not None and math.isfinite(v)
        figs[key] = {"value": v if ok else None, "se": se if ok and se is not None and math.isfinite(se) else None,
                     "truth": truth.get(key), "reason": e.get("reason")}
    return {"status": out.status, "wall_s": wall, "acquisition_s": clock.t.acquisition_s,
            "analysis_s": clock.t.analysis_s, "frames": sum(s_["frames"] + (s_.get("dark_frames") or 0) * (
                s_.get("dark_source") == "grab") for s_ in out.stages), "figures": figs}
