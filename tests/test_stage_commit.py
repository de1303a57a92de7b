"""Stages analysed and committed beside the next stage's acquisition (``ares.scan.commit``):
the same run directory as one thread, errors reach the run, nothing committed is lost."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import h5py
import numpy as np
import pytest

from ares.errors import StorageError
from ares.protocol import load_scan
from ares.scan import Runner, events as ev
from ares.scan.commit import StageCommitter
from ares.rundir.writer import RunWriter
from run_files import stage_results

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small"


def _arrays(run_dir: Path) -> dict:
    out = {}
    for p in sorted((run_dir / "stages").glob("*.h5")):
        with h5py.File(p, "r") as f:
            out[p.name] = {k: f[k][()] for k in f}
    return out


@pytest.mark.parametrize("scan", ["ptc_small.xml", "bias_small.xml"])
def test_pipelined_run_equals_one_thread(tmp_path, scan, monkeypatch):
    """One thread (as for frames above 4 Mpx) also releases the simulator's cached maps
    after each stage: the same run directory either way."""
    from ares.sim.bench import SimFrameSource

    import dataclasses

    sc = load_scan(SMALL / scan)
    sc = dataclasses.replace(sc, output=dataclasses.replace(sc.output, pdf=False))  # (stages, arrays, results compared)
    seen = {}
    released = []
    real = SimFrameSource.release
    monkeypatch.setattr(SimFrameSource, "release", lambda self: (released.append(1), real(self)))
    for pipe in (False, True):
        events = []
        released.clear()
        out = Runner(sc, out_dir=tmp_path / str(pipe), seed=5, pipeline=pipe, listeners=(events.append,)).run()
        assert out.status == "done"
        assert len(released) == (0 if pipe else len(out.stages))
        seen[pipe] = (out, events)
    (a, _), (b, eb) = seen[False], seen[True]
    assert stage_results(tmp_path / "False") == stage_results(tmp_path / "True")
    arr_a, arr_b = _arrays(tmp_path / "False"), _arrays(tmp_path / "True")
    assert arr_a.keys() == arr_b.keys()
    for k in arr_a:
        assert arr_a[k].keys() == arr_b[k].keys()
        for name in arr_a[k]:
            np.testing.assert_array_equal(arr_a[k][name], arr_b[k][name])
    assert json.dumps(a.scan_results, sort_keys=True, default=str) == json.dumps(b.scan_results, sort_keys=True,
                                                                                  default=str)
    # every stage finished once, in order, before Ending
    fin = [e.index for e in eb if isinstance(e, ev.StageFinished)]
    assert fin == list(range(len(a.stages)))
    kinds = [type(e) for e in eb]
    assert kinds.index(ev.Ending) > max(i for i, k in enumerate(kinds) if k is ev.StageFinished)


def test_a_failing_commit_fails_the_run_and_keeps_the_stages_before(tmp_path, monkeypatch):
    sc = load_scan(SMALL / "ptc_small.xml")
    real = RunWriter.add_stage
    calls = []

    def add_stage(self, result, *a, **k):
        calls.append(result["index"])
        if result["index"] == 2:
            raise StorageError(f"{self.dir / 'stages'}: no space left on device")
        return real(self, result, *a, **k)

    monkeypatch.setattr(RunWriter, "add_stage", add_stage)
    with pytest.raises(StorageError, match="no space left"):
        Runner(sc, out_dir=tmp_path / "r", seed=1).run()
    meta = json.loads((tmp_path / "r" / "run.json").read_text())
    assert meta["status"] == "failed" and "no space left" in meta["message"]
    assert [p.stem for p in sorted((tmp_path / "r" / "stages").glob("*.json"))] == ["0000", "0001"]
    assert calls == [0, 1, 2]  # nothing after the failed commit was committed


def test_committer_order_errors_and_settle():
    done, gate = [], threading.Event()

    def work(i):
        if i == 0:
            gate.wait(60)
        if i == 2:
            raise ValueError("stage 2 broke")
        done.append(i)

    c = StageCommitter(work)
    c.submit(0)
    gate.set()
    c.submit(1)  # waits for 0 first
    c.wait()
    assert done == [0, 1]
    c.submit(2)
    with pytest.raises(ValueError, match="stage 2"):
        c.submit(3)  # the error of the stage before comes out here
    assert done == [0, 1]
    c.submit(2)
    c.settle()  # logged, not raised
    c.wait()  # nothing left to raise
    one = StageCommitter(work, threaded=False)
    with pytest.raises(ValueError):
        one.submit(2)


def test_a_commit_is_timed_by_its_thread_s_cpu_not_by_the_wall_clock():
    """The run waits for the last stage's commit when it has the cores to itself, so the
    Time Remaining charges a commit's CPU time: waiting (here on an event, as a commit
    beside the next stage's frames waits for the cores) is not counted; work is."""
    import time

    gate = threading.Event()

    def waits():
        gate.wait(0.3)

    def works():
        c0 = time.thread_time()
        while time.thread_time() - c0 < 0.05:
            pass

    for threaded in (True, False):
        c = StageCommitter(waits, threaded=threaded)
        c.submit()
        c.wait()
        assert c.cpu_seconds < 0.05, c.cpu_seconds  # 0.3 s of waiting
        c = StageCommitter(works, threaded=threaded)
        c.submit()
        c.wait()
        assert c.cpu_seconds >= 0.05
