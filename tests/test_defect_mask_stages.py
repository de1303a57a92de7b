"""One defect mask for a whole scan (issue 34): the masked figures of every stage -- each
PTC level and the headline PRNU/DSNU -- use the same mask, built from the first dark's
classes (stuck, noisy, dark outliers) and the flat classes (dead, low/high response) of
the first flat whose signal shows them. Dead pixels are seen only in a flat: before, the
mask came from the dark stage alone and PRNU was 27 SE above the simulator's truth.

The main job (scans/photon_transfer.xml) on a 120 x 160 simulator with 3000 ppm dead
pixels (response 0.3: unmasked they add ~1.5e-3 to a PRNU variance of 1e-4), 8 frames.
"""

import dataclasses
import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from ares.sim.from_system import sim_params
from ares.protocol import load_scan
from ares.scan import Runner
from ares.sim import make_sim_bench

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    scan = load_scan(ROOT / "scans" / "photon_transfer.xml")
    params = dataclasses.replace(sim_params(scan.system), rows=120, cols=160, dead_rate_ppm=3000.0)
    sim_ = scan.system.simulator
    sim_ = dataclasses.replace(sim_, params={**sim_.params, "rows": 120, "cols": 160})
    system = dataclasses.replace(scan.system, sensor=dataclasses.replace(scan.system.sensor, rows=120, cols=160),
                                 simulator=sim_)
    scan = dataclasses.replace(scan, system=system, output=dataclasses.replace(scan.output, pdf=False, csv=False))
    bench = make_sim_bench(params, 3)
    events = []
    out = Runner(scan, bench=bench, out_dir=tmp_path_factory.mktemp("mask") / "run", seed=3, frames=8,
                 listeners=(events.append,)).run()
    assert out.status == "done", out.message
    rd = Path(out.run_dir)
    res = json.loads((rd / "scan_results.json").read_text())["analyses"]
    stages = [json.loads(p.read_text()) for p in sorted((rd / "stages").glob("*.json"))]
    return scan, bench, rd, res, stages, events


def test_every_stage_uses_the_one_mask_with_the_dead_pixels(run):
    scan, bench, rd, res, stages, events = run
    summaries = {json.dumps(s["defect_mask"], sort_keys=True) for s in stages}
    assert len(summaries) == 1, summaries
    mask = stages[0]["defect_mask"]
    assert "flat stage" in mask["mask_source"]
    assert all("level_masked" in s["views"]["full"] for s in stages)
    with h5py.File(rd / "stages" / "0000.h5") as f:
        m = f["defect_mask"][()].astype(bool)
    truth = bench.info["sensor"].truth()
    dr, dc = truth["defects"]["dead"]
    assert dr.size >= 30
    assert m[dr, dc].all(), f"{np.count_nonzero(~m[dr, dc])} of {dr.size} dead pixels not masked"
    assert m.sum() == mask["masked_pixels"]
    assert res["defects"]["counts"]["dead"] == dr.size


def test_prnu_masked_within_3_se_of_the_truth(run):
    scan, bench, rd, res, stages, events = run
    dec = res["decomposition"]
    from test_scan_truth import _truth

    st = next(s for s in stages if s["name"] == dec["stage"])
    want = _truth(scan, bench, st["settings"])["realized"]["Pg"]
    pg, raw = dec["components"]["Pg"], dec["components_unmasked"]["Pg"]
    assert abs(pg["value"] - want) <= 3 * pg["se"], (pg, want)
    # the dead pixels matter: with them the same figure is far off (the test can fail)
    assert abs(raw["value"] - want) > 10 * raw["se"], (raw, want)
    assert math.isfinite(pg["se"]) and pg["se"] > 0


def test_a_mask_too_short_for_the_noisy_test_makes_the_masked_ps_a_bound(run):
    """At 8 dark frames the noisy test cannot run (it needs >= 19): noisy pixels and slow
    telegraph traps stay unmasked and read as pixel FPN of the stack (photon_transfer at 16
    frames: 3 of 24 masked Ps "ok" beyond 3 SE, benchmarks/truth_z.md). The mask says so, the
    masked Ps is an upper limit that holds the defect-free truth, and so is the DSNU made
    from it."""
    from ares.report.headline import nonuniformity

    scan, bench, rd, res, stages, events = run
    dec = res["decomposition"]
    assert "noisy" in dec["mask_incomplete"] and "needs >= " in dec["mask_incomplete"]["noisy"]
    ps = dec["components"]["Ps"]
    assert ps["verdict"] == "upper limit" and "defect mask incomplete" in ps["note"], ps
    from test_scan_truth import _truth

    st = next(s for s in stages if s["name"] == dec["stage"])
    truth = _truth(scan, bench, st["settings"])["realized"]["Ps"]
    assert truth <= ps["value"], (ps, truth)
    assert dec["components"]["Cs"]["verdict"] == "ok"  # (a few pixels a line: the line FPN stays an estimate)
    figs = nonuniformity(dec["components"], dec["components_unmasked"], None, st["name"], "", st.get("scene"))
    assert figs["dsnu_dn"].verdict == "upper limit", figs["dsnu_dn"]
    from ares.rundir.summary import summary_row

    rows = [summary_row(s, scan.system.setting_units()) for s in stages]  # summary.csv says it beside the number
    rows = [r for r in rows if r.get("Ps_masked_dn2") is not None]
    assert rows and all(r["Ps_masked_verdict"] == "upper limit" for r in rows)
    import io

    from ares.commands.run_summary import print_headline

    buf = io.StringIO()  # the terminal's summary says why
    print_headline(res, buf)
    assert "mask incomplete, noisy: needs >= " in buf.getvalue(), buf.getvalue()


def test_stages_are_committed_as_they_end_and_rewritten_when_the_mask_completes(run):
    """No stage waits for the flat (a crash loses at most the stage in flight): each
    StageFinished comes before the stage after next starts (one stage in the committer),
    with the dark stage's provisional mask until the completing flat; those stages are then
    rewritten (StageUpdated) with the mask every stage ends with."""
    from ares.scan import events as ev

    scan, bench, rd, res, stages, events = run
    order = [(type(e).__name__, e.index) for e in events if isinstance(e, (ev.StageStarted, ev.StageFinished))]
    for name, i in order:
        if name == "StageStarted" and i >= 2:
            assert ("StageFinished", i - 2) in order[:order.index((name, i))], (i, order)
    finished = {e.index: e.result for e in events if isinstance(e, ev.StageFinished)}
    updated = {e.index: e.result for e in events if isinstance(e, ev.StageUpdated)}
    provisional = sorted(i for i, r in finished.items() if "provisional" in r["defect_mask"])
    completing = stages[0]["defect_mask"]["mask_source"].split("flat stage ")[1]
    k = next(s["index"] for s in stages if s["name"] == completing)
    assert provisional == list(range(k)) and k >= 2, (provisional, k)
    assert sorted(updated) == provisional
    flats = [i for i in provisional if finished[i]["scene"] == "flat"]
    assert flats and all(updated[i]["defect_mask"]["masked_pixels"] > finished[i]["defect_mask"]["masked_pixels"]
                         for i in flats)
    pg = [(finished[i]["views"]["full"]["components_masked"]["Pg"]["value"],
           updated[i]["views"]["full"]["components_masked"]["Pg"]["value"]) for i in flats]
    assert all(b < a for a, b in pg), pg  # the dead pixels (response 0.3) leave the PRNU
    for st in stages:  # on disk: the updated result (what the reports read)
        want = updated.get(st["index"], finished[st["index"]])
        assert st["defect_mask"] == want["defect_mask"] and "provisional" not in st["defect_mask"]
        assert st["views"]["full"]["components_masked"] == json.loads(json.dumps(want["views"]["full"]["components_masked"]))


def test_a_run_stopped_before_the_flat_keeps_its_stages_provisional_and_resumes_to_the_same_files(tmp_path, capsys):
    """Stopped while the mask waits for its flat: every ended stage is on disk with the dark
    stage's mask, marked provisional, and the terminal says so; `ares resume` acquires those
    stages again from the mask's dark stage (run.json names them) and ends with the files of
    an uninterrupted run."""
    import io

    from ares.cli import main
    from ares.commands.run import print_summary
    from ares.scan import events as ev

    xml = ROOT / "fixtures" / "xml" / "small" / "ptc_small.xml"
    ref = tmp_path / "ref"
    assert main(["run", str(xml), "--out", str(ref), "--quiet"]) == 0
    scan = load_scan(xml)
    r = Runner(scan, out_dir=tmp_path / "run", seed=scan.system.simulator.seed)
    r.add_listener(lambda e: r.stop() if isinstance(e, ev.StageStarted) and e.index == 2 else None)
    out = r.run()
    assert out.status == "stopped"
    d = tmp_path / "run"
    got = [json.loads(p.read_text()) for p in sorted((d / "stages").glob("*.json"))]
    assert [s["index"] for s in got] == [0, 1, 2]
    assert all("provisional" in s["defect_mask"] for s in got)
    text = io.StringIO()
    print_summary(out, scan, 1.0, out=text)
    assert "provisional: the first dark stage's classes only" in text.getvalue()
    capsys.readouterr()
    assert main(["resume", str(d), "--quiet"]) == 0
    meta = json.loads((d / "run.json").read_text())
    assert meta["status"] == "done" and meta["resumed"][-1]["acquired_again"] == [0, 1, 2]
    want = {p.name: json.loads(p.read_text()) for p in sorted((ref / "stages").glob("*.json"))}
    have = {p.name: json.loads(p.read_text()) for p in sorted((d / "stages").glob("*.json"))}
    assert list(have) == list(want)
    for name in want:
        for key in ("views", "settings", "bench_position", "defect_mask"):
            assert have[name][key] == want[name][key], (name, key)
    assert json.loads((d / "scan_results.json").read_text()) == json.loads((ref / "scan_results.json").read_text())


def test_a_kill_inside_a_stage_rewrite_leaves_a_readable_run(run, tmp_path):
    """A stage rewritten with the completed mask (RunWriter.replace_stage) is a two-phase
    commit: run.json first learns the new JSON's hash ("stage_sha256_replacing"), then the
    file is replaced, then the hash is recorded. A SIGKILL after the file but before the last
    run.json left "corrupt: stage 0 ... differs from the SHA-256 recorded" and the resumed
    run's reports failed (test_signal_campaign, seed 4); now either hash is the stage's."""
    import hashlib
    import shutil

    from ares.rundir.check import RunDamaged, check_stage_files

    rd = tmp_path / "run"
    shutil.copytree(run[2], rd)
    meta = json.loads((rd / "run.json").read_text())
    assert "stage_sha256_replacing" not in meta  # a finished rewrite leaves no trace
    now = hashlib.sha256((rd / "stages" / "0000.json").read_bytes()).hexdigest()
    assert meta["stage_sha256"]["0000"] == now
    provisional = dict(meta, stage_sha256={**meta["stage_sha256"], "0000": "0" * 64})
    with pytest.raises(RunDamaged, match="stage 0"):  # the file replaced, run.json still the provisional hash
        check_stage_files(rd, provisional)
    check_stage_files(rd, dict(provisional, stage_sha256_replacing={"0000": now}))  # killed after the file
    check_stage_files(rd, dict(meta, stage_sha256_replacing={"0000": "0" * 64}))  # killed before the file
