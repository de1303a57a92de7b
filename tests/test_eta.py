"""Time remaining (ares.scan.eta) from measured frame and stage times, fed made-up event
times (no clock): exact for a steady scan once one stage has ended, and it does not
carry the first stage's one-off work or its slower frames into every later estimate."""

from __future__ import annotations

import time
from types import SimpleNamespace

import pytest

from ares.scan.eta import Eta


def simulate(eta: Eta, stages: list[tuple[int, float, float]], upto: int):
    """Feed ``upto`` stages of (frames, s/frame, s of stage work); return (ETA, the true time
    left, the old frames-left / overall-rate estimate) after the first frame of stage ``upto``."""
    t = 0.0
    out = None
    done = 0
    n_total = sum(n for n, _, _ in stages)
    total = sum(n * f + w for n, f, w in stages)
    for i, (n, per_frame, work) in enumerate(stages):
        eta.stage_started(t)
        t += work / 2  # settling before the first frame
        for _ in range(n):
            t += per_frame
            eta.frame(t)
            done += 1
            if i == upto and out is None:
                out = (eta.remaining(t), total - t - (work / 2), (n_total - done) * t / done)
        t += work / 2  # the stage's analysis and write
        eta.stage_finished(t)
    return out


def errors_from(eta: Eta, stages, check_from: int) -> list[float]:
    """Feed stages of one stack each, (s before its first stack, frames, s/frame, s of
    work after its frames, scene or None); return ETA / true time left - 1 at the second
    frame of every stage from ``check_from`` on."""
    total = sum(before + n * f + after for before, n, f, after, _ in stages)
    t, errors = 0.0, []
    for i, (before, n, per_frame, after, scene) in enumerate(stages):
        t += before
        eta.stage_started(t, "dark" if scene == "dark" else scene and "flat")
        for k in range(n):
            t += per_frame
            eta.frame(t)
            if i >= check_from and k == 1:
                errors.append(eta.remaining(t) / (total - t) - 1)
        t += after
        eta.stage_finished(t, scene)
    return errors


def test_steady_scan_is_exact_after_the_first_stage():
    stages = [(16, 0.01, 0.5)] * 10
    got, true, _ = simulate(Eta(160, 10), stages, upto=1)
    assert got == pytest.approx(true, rel=0.07)  # one frame interval of the new stack is unknown


def test_first_stage_one_off_work_and_slow_frames_do_not_dominate():
    stages = [(32, 0.03, 3.0)] + [(16, 0.01, 0.5)] * 20
    got, true, naive = simulate(Eta(32 + 320, 21), stages, upto=3)
    assert got == pytest.approx(true, rel=0.10)
    assert abs(naive / true - 1) > 0.3  # the old estimate (frames left / overall rate) is far off


def test_nothing_measured_gives_the_prior():
    assert Eta(10, 2, prior_s=3.0).remaining(0.0) == 3.0
    assert Eta(10, 2).remaining(0.0) is None


def test_dark_and_flat_frames_are_charged_at_their_own_rates():
    """A dark stack costs 1 ms a frame, a flat one 4 ms (a bright simulated frame clips, a
    real one is read out longer): after one flat stage the time left is within 5 % of the
    truth at every later stage's first frame, where one rate for all frames (the previous
    stack's, a dark) reads far low."""
    stages = [("dark", 32, 0.0)] + [("flat", 16, 16)] * 10  # (scene, frames, matched dark frames)
    kinds = {"dark": 32 + 10 * 16, "flat": 10 * 16}
    rate = {"dark": 0.001, "flat": 0.004}
    work = 0.02
    plan = []  # (kind, frames) stacks in order
    for scene, n, nd in stages:
        plan.append([("dark", nd)] if nd else [])
        plan[-1].append((scene, n))
    total = sum(n * rate[k] for stacks in plan for k, n in stacks) + work * len(plan)
    for per_kind in (True, False):
        eta = Eta(sum(kinds.values()), len(plan), 0.0,
                  stacks=[(k, n, 0.0) for k, n in kinds.items()] if per_kind else None)
        t, errors = 0.0, []
        for i, stacks in enumerate(plan):
            for j, (kind, n) in enumerate(stacks):
                eta.stage_started(t, kind if per_kind else None)
                if j == 0:
                    t += work / 2
                for f in range(n):
                    t += rate[kind]
                    eta.frame(t)
                    if i >= 2 and kind == "flat" and f == 0:
                        errors.append(eta.remaining(t) / (total - t) - 1)
            t += work / 2
            eta.stage_finished(t)
        worst = max(abs(e) for e in errors)
        if per_kind:
            assert worst < 0.05, errors
        else:
            assert worst > 0.2  # the single-rate estimate this replaces


def test_stage_work_is_charged_per_scene_and_the_first_stage_one_off_left_out():
    """A dark stage's analysis is lighter (0.05 s) than a flat's (0.3 s) and the run's first
    stage carries 2 s of one-off work (the defect mask): after one dark and one flat stage
    beyond the first, the time left is exact on a steady scan."""
    plan = ["dark"] + ["flat", "dark"] * 10  # (e.g. dark-current / lag cycles)
    work = {"dark": 0.05, "flat": 0.3}
    per_frame, n = 0.002, 8
    eta = Eta(len(plan) * n, len(plan), 0.0, stages_by_scene={"dark": plan.count("dark"),
                                                              "flat": plan.count("flat")})
    errors = errors_from(eta, [(0.0, n, per_frame, work[sc] + (2.0 if i == 0 else 0.0), sc)
                               for i, sc in enumerate(plan)], check_from=3)
    assert max(abs(e) for e in errors) < 0.02, errors


def test_one_off_work_of_the_first_stage_is_not_charged_to_the_next():
    """At the second stage only the first has ended: its defect-mask time (one-off) must not
    be charged to every stage still to come."""
    def at_second_stage(one_off: bool) -> float:
        eta = Eta(32 + 16 * 10, 11)
        t = 0.0
        eta.stage_started(t)
        for _ in range(32):
            t += 0.01
            eta.frame(t)
        t += 0.05  # stage work every stage has
        if one_off:
            eta.one_off(2.0)
        t += 2.0  # the defect mask, once
        eta.stage_finished(t)
        eta.stage_started(t)
        t += 0.01
        eta.frame(t)
        return eta.remaining(t)

    true = 15 * 0.01 + 9 * 16 * 0.01 + 10 * 0.05  # frames left and ten stages' work
    assert at_second_stage(True) == pytest.approx(true, rel=0.05)
    assert at_second_stage(False) > 5 * true  # charged to all ten: what it did before


def test_an_exposure_sweep_is_charged_by_each_stage_s_exposure():
    """A dark-current sweep on a real sensor: frames take exposure + readout + the
    grabber's 2 ms, 10 ms to 1 s. With each stack's model time (exposure + readout) the
    time left is within 2 % from the second stage on; without it (every frame at the
    latest rate) it reads far low -- the first stages' short frames charged to the long
    ones."""
    exposures = [0.01 + 0.99 * i / 7 for i in range(8)]
    readout, n, work, overhead = 0.005, 8, 0.05, 0.002  # the grabber's own time a frame
    for model in (True, False):
        stacks = [("dark", n, e + readout if model else 0.0) for e in exposures]
        eta = Eta(n * len(exposures), len(exposures), 0.0, stacks=stacks)
        errors = errors_from(eta, [(0.0, n, e + readout + overhead, work, "dark") for e in exposures], check_from=1)
        worst = max(abs(e) for e in errors)
        if model:
            assert worst < 0.02, errors
        else:
            assert worst > 0.5, errors


def test_stacks_cost_exposure_plus_readout_only_on_a_paced_bench():
    from ares.protocol import load_scan
    from ares.scan.eta import eta_stacks as _stacks
    from ares.scan.stages import expand, frame_seconds

    scan = load_scan("scans/dark_current.xml")
    stages = expand(scan)
    paced = _stacks(scan, stages, SimpleNamespace(exposure_paced=True))
    assert sum(n for _, n, _, _ in paced) == sum(st.frames_to_grab() for st in stages)
    readout = scan.system.timing.readout_s
    want = [frame_seconds(scan, st) for st in stages if st.scene == "dark"]
    assert [c for k, _, c, _ in paced][:len(want)] == want  # the sweep's dark stages come first
    assert want == pytest.approx([st.settings["exposure"] + readout for st in stages if st.scene == "dark"])
    assert max(want) > 0.5 and min(want) < 0.1  # 10 ms to 1 s
    unpaced = _stacks(scan, stages, SimpleNamespace(exposure_paced=False))
    assert {c for _, _, c, _ in unpaced} == {0.0}  # the simulator: no model
    assert {w for *_, w in paced + unpaced} == {1.0}  # a source that cannot weigh its frames


def test_time_between_stages_is_charged_as_stage_work():
    """Between one stage's end and the next one's first stack the runner sets the bench up,
    lets the light settle and waits for the previous stage's commit (0.2 s here): that is
    stage work every stage has, charged to the stages to come (it was charged to none)."""
    n, per_frame, gap, k = 16, 0.01, 0.2, 10
    errors = errors_from(Eta(n * k, k, 0.0), [(gap, n, per_frame, 0.0, None)] * k, check_from=2)
    assert max(abs(e) for e in errors) < 0.02, errors


@pytest.mark.parametrize("paced", [True, False])
def test_the_runner_plans_exposure_plus_readout_only_for_a_paced_frame_source(monkeypatch, tmp_path, paced):
    """The runner hands the time remaining each stack's model time from the frame source's
    ``exposure_paced``: exposure + readout for a real sensor's frames, none for the
    simulator's (whose frame time does not follow the exposure)."""
    from pathlib import Path

    import ares.scan.runner as R
    from ares.protocol import load_scan
    from ares.sim.bench import SimFrameSource

    small = Path(__file__).resolve().parents[1] / "fixtures" / "xml" / "small"
    text = (small / "ptc_small.xml").read_text().replace('href="sim_small.xml"', f'href="{small / "sim_small.xml"}"')
    text = text.replace('<set quantity="exposure" value="0.01"/>', '<set quantity="exposure" value="0.02"/>')
    (tmp_path / "scan.xml").write_text(text)
    scan = load_scan(tmp_path / "scan.xml")
    seen = []
    monkeypatch.setattr(SimFrameSource, "exposure_paced", paced)
    monkeypatch.setattr(R, "Eta", lambda *a, **k: seen.append(k["stacks"]) or Eta(*a, **k))
    assert R.Runner(scan, seed=1, frames=2).run().status == "done"
    models = {m for _, _, m, _ in seen[0]}
    assert models == ({0.02 + scan.system.timing.readout_s} if paced else {0.0})


def test_a_paced_simulator_is_planned_as_a_sensor_and_gives_the_same_run(tmp_path, monkeypatch):
    """``<simulator paced="true">``: the frames come at exposure + readout, so the time
    remaining plans each stack as a real sensor's (model exposure + readout, no cost
    weights, the simulator's own seconds not counted: its work hides behind the exposure);
    the frames, and so every result, are those of the unpaced simulator."""
    from pathlib import Path

    import ares.scan.runner as R
    from ares.protocol import load_scan

    small = Path(__file__).resolve().parents[1] / "fixtures" / "xml" / "small"
    system = (small / "sim_small.xml").read_text()
    assert '<simulator seed="7">' in system
    (tmp_path / "paced.xml").write_text(system.replace('<simulator seed="7">', '<simulator seed="7" paced="true">'))
    (tmp_path / "plain.xml").write_text(system)
    seen, computes, results = [], [], {}
    monkeypatch.setattr(R, "Eta", lambda *a, **k: seen.append(k["stacks"]) or Eta(*a, **k))
    monkeypatch.setattr(Eta, "frame", lambda self, t, compute=None, _f=Eta.frame: computes.append(compute) or _f(self, t, compute))
    for name in ("plain", "paced"):
        text = (small / "ptc_small.xml").read_text().replace('href="sim_small.xml"', f'href="{name}.xml"').replace(
            '<output raw_frames="true"/>', '<output raw_frames="true" pdf="false"/>')  # (the CSVs are compared)
        assert 'pdf="false"' in text
        (tmp_path / f"{name}_scan.xml").write_text(text)
        scan = load_scan(tmp_path / f"{name}_scan.xml")
        assert scan.system.simulator.paced == (name == "paced")
        r = R.Runner(scan, out_dir=tmp_path / name, seed=1, frames=2)
        t0 = time.monotonic()
        assert r.run().status == "done"
        took = time.monotonic() - t0
        results[name] = {f: (tmp_path / name / f).read_bytes() for f in ("key_figures.csv", "ptc.csv", "components.csv")}
    frames = sum(n for _, n, _, _ in seen[1])
    period = 0.01 + scan.system.timing.readout_s
    assert {m for _, _, m, _ in seen[1]} == {period} and {w for *_, w in seen[1]} == {1.0}
    assert {m for _, _, m, _ in seen[0]} == {0.0}  # the plain simulator: no model, weighed by its cost
    assert set(computes[-frames:]) == {None} and None not in computes[:frames]
    assert took >= frames * period  # (a lower bound: a slow machine only adds to it)
    assert results["paced"] == results["plain"]


def test_stacks_weighed_by_their_frames_cost_are_charged_by_it():
    """make run on the simulator: a dark stage, 11 low-light stages whose exact Poisson
    frames cost the simulator 4.55 ms, 14 brighter ones 2.75 ms (``ares.sim.cost``'s
    units), each frame also taking 1.2 ms (0.7 in the dark stage) of accumulation and the
    previous stage's analysis beside it. With each stack's cost and the simulator's own
    seconds (``compute``), the brighter stages are charged their own time before any has
    run: within 3 % from the second stage on; without, they are charged at the low-light
    rate (20 %+ high)."""
    costs = [1.8] + [4.55] * 11 + [2.75] * 14
    rest = [7e-4] + [1.2e-3] * 25
    total = sum(0.01 + (32 if i == 0 else 16) * (c * 1e-3 + r) + 0.005 for i, (c, r) in enumerate(zip(costs, rest)))
    worst = {}
    for weighed in (True, False):
        stacks = [("dark" if i == 0 else "flat", 32 if i == 0 else 16, 0.0, c if weighed else 1.0)
                  for i, c in enumerate(costs)]
        eta = Eta(sum(n for _, n, *_ in stacks), len(stacks), 0.0, stacks=stacks,
                  stages_by_scene={"dark": 1, "flat": len(stacks) - 1})
        t, made, errors = 0.0, 0.0, []
        for i, ((kind, n, _, _), c, r) in enumerate(zip(stacks, costs, rest)):
            t += 0.01
            eta.stage_started(t, kind)
            for f in range(n):
                t += c * 1e-3 + r
                made += c * 1e-3
                eta.frame(t, made if weighed else None)
                if i >= 1 and f == 1:
                    errors.append(eta.remaining(t) / (total - t) - 1)
            t += 0.005
            eta.stage_finished(t, kind)
        worst[weighed] = max(abs(e) for e in errors)
    assert worst[True] < 0.03, worst
    assert worst[False] > 0.20, worst


def test_the_simulator_weighs_make_run_s_stages_by_their_path():
    """The runner's stacks for make run's scan on the simulator: the low-light stages
    (exact Poisson by the alias method) cost more a frame than the brighter ones, the dark
    stage least; the weights come from the path ``render`` takes at each stage's settings."""
    from ares.rig.factory import build_bench
    from ares.protocol import load_scan
    from ares.scan.eta import eta_stacks as _stacks
    from ares.scan.stages import expand
    from ares.sim import cost

    scan = load_scan("scans/photon_transfer.xml")
    bench = build_bench(scan.system, seed=1)
    try:
        stacks = _stacks(scan, expand(scan), bench.frames)
    finally:
        bench.close()
    weights = [w for *_, w in stacks]
    alias = cost.BASE + cost.DRAW[cost.fused.ALIAS] + cost.DRAW[cost.fused.GAUSS] + cost.LOOKUP
    gauss = cost.BASE + 2 * cost.DRAW[cost.fused.GAUSS] + cost.LOOKUP
    dark = cost.BASE + cost.DRAW[cost.fused.GAUSS] + cost.LOOKUP
    assert weights == pytest.approx([dark] + [alias] * 11 + [gauss] * 14)


def test_the_wait_for_the_last_stage_s_analysis_is_charged():
    """Each stage's analysis and write (0.1 s here) runs beside the next stage's frames,
    so only the last one is waited for after the last frame. Told how long the latest
    took (``end_work``: known once the second stage is in), the time left is within 2 %
from the third stage to the last;
    untold, the last stages read far low (a third of the time left at the last stage)."""
    n, per_frame, gap, commit, k = 16, 0.01, 0.005, 0.1, 10
    total = k * (gap + n * per_frame) + commit
    worst = {}
    for told in (True, False):
        eta, t, errors = Eta(n * k, k, 0.0), 0.0, []
        for i in range(k):
            t += gap
            eta.stage_started(t)
            for f in range(n):
                t += per_frame
                eta.frame(t)
                if i >= 2 and f == 1:
                    errors.append(eta.remaining(t) / (total - t) - 1)
            eta.stage_finished(t)
            if told and i:  # the runner learns a commit's time when it submits the next stage
                eta.end_work(commit)
        worst[told] = max(abs(e) for e in errors)
    assert worst[True] < 0.02, worst
    assert worst[False] > 0.3, worst


def test_a_frame_source_that_fails_to_cost_its_frames_does_not_stop_the_scan(caplog):
    """``frame_cost`` only weighs the time remaining: a source whose costing raises (a bug,
    a device that cannot tell) gets unweighted stacks and a log line, and the scan runs."""
    from ares.protocol import load_scan
    from ares.scan.eta import eta_stacks as _stacks
    from ares.scan.stages import expand

    def broken(fields):
        raise ZeroDivisionError("no cost model")

    scan = load_scan("scans/photon_transfer.xml")
    stacks = _stacks(scan, expand(scan), SimpleNamespace(exposure_paced=False, frame_cost=broken, name="grabber"))
    assert {w for *_, w in stacks} == {1.0}
    assert caplog.text.count("could not cost") == 1 and "grabber" in caplog.text
