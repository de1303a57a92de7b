"""Fault campaign (issue 10): hardware faults, SIGKILL and SIGTERM at seeded random points,
disk full, a read-only output, broken and hostile XML. For every case: one clear sentence,
the right exit code, the run's state on disk true, every committed stage readable, and
``ares resume`` completing the run with stage results identical to an uninterrupted run
with the same seed. Bounded: small scans, waits on files appearing (minutes at most)."""

from __future__ import annotations

import errno
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest

from ares.cli import main
from ares.rundir.state import effective_status

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small"
SCAN = SMALL / "ptc_small.xml"  # without its PDF, below


@pytest.fixture(scope="module", autouse=True)
def _scan_without_pdf(ptc_small_no_pdf):
    """These runs compare statuses, stages and scan results, never the PDF."""
    global SCAN
    SCAN = ptc_small_no_pdf
RESULT_KEYS = ("views", "settings", "registers_after", "bench_position", "defect_mask")


def stages_of(d: Path) -> dict[str, dict]:
    return {p.name: json.loads(p.read_text()) for p in sorted((d / "stages").glob("[0-9][0-9][0-9][0-9].json"))}


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The uninterrupted run every resumed one must reproduce."""
    d = tmp_path_factory.mktemp("ref") / "run"
    assert main(["run", str(SCAN), "--out", str(d), "--quiet"]) == 0
    return d


def assert_committed_readable(d: Path) -> int:
    """Every stage whose JSON exists has its arrays; returns the count."""
    st = stages_of(d)
    for name in st:
        with h5py.File(d / "stages" / name.replace(".json", ".h5"), "r") as f:
            assert f["mean"].shape == (24, 32)
    return len(st)


def assert_resumes_to_reference(d: Path, ref: Path, capsys) -> None:
    capsys.readouterr()
    assert main(["resume", str(d), "--quiet"]) == 0
    got, want = stages_of(d), stages_of(ref)
    assert list(got) == list(want)
    for name in want:
        for key in RESULT_KEYS:
            assert got[name].get(key) == want[name].get(key), (name, key)
    meta = json.loads((d / "run.json").read_text())
    assert meta["status"] == "done" and meta["resumed"]
    assert json.loads((d / "scan_results.json").read_text()) == json.loads((ref / "scan_results.json").read_text())


# the disconnect in the suite; the short frame in make bench-quick (short frames themselves: test_scan_runner,
# test_sim_bench, test_usb_transient)
@pytest.mark.parametrize("fault", ["disconnect_after_frames=13",
                                   pytest.param("short_frame_at=22", marks=pytest.mark.study)])
def test_hardware_fault_then_resume(fault, tmp_path, reference, capsys):
    d = tmp_path / "run"
    rc = main(["run", str(SCAN), "--out", str(d), "--quiet", "--sim-fault", fault])
    err = capsys.readouterr().err
    assert rc == 3 and err.count("\n") == 1 and "sim grabber" in err and "Traceback" not in err
    assert json.loads((d / "run.json").read_text())["status"] == "failed"
    assert 0 < assert_committed_readable(d) < len(stages_of(reference))
    assert_resumes_to_reference(d, reference, capsys)


def _spawn(d: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "ares.cli", "run", str(SCAN), "--out", str(d), "--quiet",
                             "--sim-fault", "frame_delay_ms=15"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env={**os.environ, "PYTHONPATH": str(ROOT)})


def _wait_for(path: Path, proc: subprocess.Popen, timeout: float = 600.0) -> bool:
    t0 = time.monotonic()
    while not path.exists():
        if proc.poll() is not None or time.monotonic() - t0 > timeout:
            return False
        time.sleep(0.01)
    return True


@pytest.mark.parametrize("seed", [1, pytest.param(2, marks=pytest.mark.study), pytest.param(3, marks=pytest.mark.study)])
def test_sigkill_at_a_random_point_then_resume(seed, tmp_path, reference, capsys):
    k = random.Random(seed).randint(1, 6)
    d = tmp_path / "run"
    proc = _spawn(d)
    assert _wait_for(d / "stages" / f"{k:04d}.json", proc), proc.communicate()
    time.sleep(random.Random(seed).uniform(0, 0.05))  # somewhere inside the next stage
    proc.kill()
    proc.wait(timeout=600)
    meta = json.loads((d / "run.json").read_text())
    assert meta["status"] == "running" and meta["pid"] == proc.pid
    status, why = effective_status(meta)
    assert status == "interrupted" and "is gone" in why
    n = assert_committed_readable(d)
    assert n >= k + 1
    capsys.readouterr()
    assert main(["report", str(d), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["status"] == "interrupted" and rep["complete"] is False
    assert_resumes_to_reference(d, reference, capsys)


def test_sigterm_stops_like_ctrl_c_then_resume(tmp_path, reference, capsys):
    d = tmp_path / "run"
    proc = _spawn(d)
    assert _wait_for(d / "stages" / "0002.json", proc)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 130, err
    assert b"SIGTERM: stopping after the current stage" in err
    meta = json.loads((d / "run.json").read_text())
    assert meta["status"] == "stopped"
    assert_committed_readable(d)
    assert_resumes_to_reference(d, reference, capsys)


def test_disk_full_is_one_sentence_and_resumable(tmp_path, reference, capsys, monkeypatch):
    """ENOSPC while committing stage 4: exit 5, one sentence naming the path, run.json
    'failed', stages 0-3 intact; once there is room again, resume completes the run."""
    import ares.rundir.writer as rd

    real = rd.dump_json

    def full(path, obj):
        if path.name == "0004.json":
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, obj)

    monkeypatch.setattr(rd, "dump_json", full)
    d = tmp_path / "run"
    rc = main(["run", str(SCAN), "--out", str(d), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 5 and err.count("\n") == 1 and "the disk is full" in err and "stages" in err
    assert json.loads((d / "run.json").read_text())["status"] == "failed"
    assert assert_committed_readable(d) == 4
    assert not list((d / "stages").glob("*.tmp"))
    monkeypatch.setattr(rd, "dump_json", real)
    assert_resumes_to_reference(d, reference, capsys)


def test_read_only_output_is_one_sentence(tmp_path, capsys, monkeypatch):
    real = Path.mkdir

    def ro(self, *a, **k):
        if self.name == "run":
            raise OSError(errno.EROFS, "Read-only file system", str(self))
        return real(self, *a, **k)

    monkeypatch.setattr(Path, "mkdir", ro)
    rc = main(["run", str(SCAN), "--out", str(tmp_path / "run"), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 5 and err.count("\n") == 1 and "read-only" in err and str(tmp_path / "run") in err


def test_a_failed_analysis_fails_the_run(tmp_path, capsys, monkeypatch):
    from ares.results import registry as results

    def broken(run):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setitem(results.SCAN_ANALYSES, "ptc", broken)
    d = tmp_path / "run"
    rc = main(["run", str(SCAN), "--out", str(d), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 1 and "scan-level analysis failed: ptc: ZeroDivisionError" in err
    meta = json.loads((d / "run.json").read_text())
    assert meta["status"] == "failed" and assert_committed_readable(d) == meta["stages_completed"] > 0


def test_resume_refuses_a_done_or_live_run(tmp_path, reference, capsys):
    assert main(["resume", str(reference)]) == 2
    assert "nothing to resume" in capsys.readouterr().err
    live = tmp_path / "live"
    live.mkdir()
    for p in ("xml", "stages"):
        os.symlink(reference / p, live / p)
    meta = json.loads((reference / "run.json").read_text())
    meta.update(status="running", pid=os.getpid(), host=os.uname().nodename, heartbeat=time.time())
    (live / "run.json").write_text(json.dumps(meta))
    assert main(["resume", str(live)]) == 2
    assert "still running" in capsys.readouterr().err


def test_resume_names_a_stage_taken_out_of_a_complete_run(tmp_path, reference, capsys):
    """A done run whose stage 1 was deleted is not complete: resume names the gap (it said
    'the run is complete (N-1 stage(s))')."""
    import shutil

    edited = tmp_path / "edited"
    shutil.copytree(reference, edited)
    for f in (edited / "stages").glob("0001.*"):
        f.unlink()
    assert main(["resume", str(edited)]) == 2
    assert "stage 1 is missing but stage 2 is there; the run directory was edited" in capsys.readouterr().err


def test_concurrent_runs_into_one_out_never_nest(tmp_path):
    out = tmp_path / "same"
    procs = [subprocess.Popen([sys.executable, "-m", "ares.cli", "run", str(SCAN), "--out", str(out), "--quiet"],
                              cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              env={**os.environ, "PYTHONPATH": str(ROOT)}) for _ in range(3)]
    for p in procs:
        p.communicate(timeout=900)
        assert p.returncode == 0
    runs = sorted(p for p in tmp_path.iterdir() if (p / "run.json").exists())
    assert len(runs) == 3
    for r in runs:  # no run directory inside another
        assert not any((c / "run.json").exists() for c in r.iterdir() if c.is_dir())


@pytest.mark.parametrize("text, fragment", [
    ("<scan", "line 1"),
    ('<?xml version="1.0"?><!DOCTYPE s [<!ENTITY x "y">]><scan name="a" version="1"/>', "DOCTYPE"),
    ('<scan name="a" version="1"><system href="/etc/shadow"/><frames>4</frames><stages/></scan>', ""),
])
def test_broken_and_hostile_xml(tmp_path, capsys, text, fragment):
    p = tmp_path / "bad.xml"
    p.write_text(text)
    for cmd in (["validate", str(p)], ["run", str(p), "--dry-run"], ["run", str(p), "--out", str(tmp_path / "r")]):
        rc = main(cmd)
        err = capsys.readouterr().err
        assert rc == 2 and "Traceback" not in err and str(p) in err, (cmd, err)
        assert fragment in err
        assert "root:" not in err  # no file content echoed
    assert not (tmp_path / "r").exists()


def test_stop_while_a_chamber_never_settles(tmp_path):
    """A chamber that never reaches its set point: the runner's stop request ends the wait
    (polled every 0.1 s, not after the 7200 s timeout), the run is 'stopped' and says so."""
    import dataclasses
    import threading

    from ares.sim.from_system import sim_params
    from ares.hardware.serial_instruments import SerialChamber
    from ares.protocol import load_scan, load_system
    from ares.scan import Runner
    from ares.sim.bench import make_sim_bench

    asked = threading.Event()

    class NeverStable:
        def write(self, data):
            asked.set() if data.startswith(b"STABLE?") else None
            self.reply = b"0\n" if data.startswith(b"STABLE?") else b"OK\n"

        def readline(self):
            return self.reply

        def close(self):
            pass

    scan = load_scan(ROOT / "scans" / "temperature.xml")
    bench = make_sim_bench(sim_params(scan.system), seed=1)
    cfg = dataclasses.replace(load_system(ROOT / "protocols" / "black_widow.xml").chamber, min=-40, max=125,
                              settle_timeout_s=7200, poll_s=5)
    bench.chamber = SerialChamber(NeverStable(), cfg)
    runner = Runner(scan, bench=bench, out_dir=tmp_path / "run", frames=2)
    stopper = threading.Thread(target=lambda: asked.wait(600) and runner.stop())
    stopper.start()
    outcome = runner.run()
    stopper.join()
    assert asked.is_set() and outcome.status == "stopped" and not outcome.stages
    assert json.loads((tmp_path / "run" / "run.json").read_text())["status"] == "stopped"
