"""Issue 54: a run killed or signalled at any instant -- before, during and after its last
stage, between the stages and ``done``, during each report, before the run's own handler
exists -- ends truthful (exit 130 or killed; run.json says what is on disk), and ``ares
resume`` completes it to tables identical to an uninterrupted run's.

The instants are places in the code, not times: the child process kills itself (or
raises a signal at itself) when it reaches a named function, so each case lands in its
window on a loaded machine as on an idle one. ``test_sweep_under_load`` (``study``)
adds 50 instants of a seeded random delay after named events of the main job while a
load generator keeps every core busy."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ares.rundir.state import effective_status
from test_signal_campaign import PROMISED, SCAN, SMALL, STAGES, none_left, tables

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "ARES_PDF_HELPER": "1"}  # (the runs' PDF helper, killed with them)

# The child: patch one function so that reaching it kills (or signals) this very process,
# then run the CLI. argv: target ("module:Class.method" or "module:function"), action
# (a signal name), nth call to act on (1 = the first), then the CLI's argv.
_CHILD = r"""
import importlib, os, signal, sys
target, action, nth, *cli = sys.argv[1:]
modname, _, attr = target.partition(":")
obj = importlib.import_module(modname)
*owner, name = attr.split(".")
for o in owner:
    obj = getattr(obj, o)
real = getattr(obj, name)
calls = [0]
def hooked(*a, **k):
    calls[0] += 1
    if calls[0] == int(nth):
        sig = getattr(signal, action)
        if sig == signal.SIGKILL:
            os.kill(os.getpid(), sig)
        signal.raise_signal(sig)  # (its handler runs at the next bytecode: in this window)
    return real(*a, **k)
setattr(obj, name, hooked)
from ares.cli import main
sys.exit(main(cli, keep_handlers=True))
"""

# (name, target, nth call): each a window of the main job
INSTANTS = {
    "last stage's arrays": ("ares.rundir.writer:RunWriter._write_stage_h5", STAGES),
    "the last stage's JSON, not its index": ("ares.rundir.writer:RunWriter._write_index", STAGES),
    "between the last stage and done": ("ares.rundir.writer:RunWriter.finish", 1),
    "the reports' tables": ("ares.report.csv_export:write_csv", 1),
    "the reports' HDF5": ("ares.report.h5_export:write_h5", 1),
    "the reports' PDF": ("ares.report.pdf_parts:write_pdf", 1),
}


@pytest.fixture(scope="module")
def scan(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("xml")
    (d / "sim_small.xml").write_bytes((SMALL / "sim_small.xml").read_bytes())
    (d / "tiny.xml").write_text(SCAN)
    return d / "tiny.xml"


@pytest.fixture(scope="module")
def reference(scan, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("ref") / "run"
    p = subprocess.run([sys.executable, "-m", "ares.cli", "run", str(scan), "--out", str(d), "--quiet"], env=ENV,
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return d


def child(scan: Path, d: Path, target: str, action: str, nth: int, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", _CHILD, target, action, str(nth), "run", str(scan), "--out", str(d),
                           "--quiet", *extra], env=ENV, capture_output=True, text=True)


def check_truthful_then_resume(d: Path, p: subprocess.CompletedProcess, reference: Path) -> None:
    assert "Traceback" not in p.stderr, p.stderr
    assert p.returncode in (-9, 130), (p.returncode, p.stderr)
    meta = json.loads((d / "run.json").read_text())
    status, _ = effective_status(meta)
    if status == "done":
        assert meta.get("reports") == "complete" and all((d / f).is_file() for f in PROMISED), meta
    else:
        assert status in ("stopped", "aborted", "interrupted", "reports incomplete"), status
    assert none_left(d)
    if status != "done":
        r = subprocess.run([sys.executable, "-m", "ares.cli", "resume", str(d), "--quiet"], env=ENV,
                           capture_output=True, text=True)
        assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    meta = json.loads((d / "run.json").read_text())
    assert effective_status(meta)[0] == "done" and meta["reports"] == "complete", (
        meta.get("status"), meta.get("reports"), meta.get("report_error"), meta.get("resumed"), p.stderr)
    assert all((d / f).is_file() for f in PROMISED)
    assert not list(d.glob("*.tmp")) and not list((d / "stages").glob("*.tmp"))
    assert tables(d) == tables(reference)
    assert none_left(d)


NORMAL = ("between the last stage and done", "the last stage's JSON, not its index")  # (the rest: study)


@pytest.mark.parametrize("instant", [i if i in NORMAL else pytest.param(i, marks=pytest.mark.study) for i in INSTANTS])
def test_sigkill_at_an_instant_then_resume_is_identical(instant, scan, reference, tmp_path):
    """A SIGKILL between the last stage and ``done`` could never be resumed (StopIteration
    from the time estimate of an empty plan, the run turned failed, results.h5.tmp left,
    every later resume the same); one after the last stage's JSON (its commit) and before
    the index and summary.csv followed left both without that stage (found by the sweep);
    at each instant now: resume completes it identically."""
    target, nth = INSTANTS[instant]
    d = tmp_path / "run"
    p = child(scan, d, target, "SIGKILL", nth)
    assert p.returncode == -9, p.stderr
    check_truthful_then_resume(d, p, reference)


def test_sigterm_after_the_last_stage_is_exit_130_and_the_run_complete(scan, reference, tmp_path):
    """A stop that lands after the last stage is committed was ignored (exit 0): now exit
    130, one sentence that the run is complete, run.json done with every report."""
    target, nth = INSTANTS["between the last stage and done"]
    d = tmp_path / "run"
    p = child(scan, d, target, "SIGTERM", nth)
    assert p.returncode == 130, p.stderr
    assert "the run is complete" in p.stderr and "Traceback" not in p.stderr, p.stderr
    check_truthful_then_resume(d, p, reference)


def test_sighup_before_the_handler_of_the_run_is_not_lost(scan, tmp_path):
    """SIGHUP while the scan XML is loaded (before the run's handler existed; the run
    inherited SIGHUP ignored, as under nohup): it was lost and the run ended done, exit 0.
    Now: exit 130, one sentence, nothing written."""
    d = tmp_path / "run"
    p = subprocess.run([sys.executable, "-c", _CHILD, "ares.protocol:load_scan", "SIGHUP", "1", "run", str(scan),
                        "--out", str(d), "--quiet"], env=ENV, capture_output=True, text=True,
                       preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    assert p.returncode == 130 and "Traceback" not in p.stderr, p.stderr
    assert "SIGHUP before the run started: nothing was written" in p.stderr, p.stderr
    assert not d.exists()


@pytest.mark.study
def test_a_signal_after_the_claim_stops_before_the_first_stage(scan, reference, tmp_path):
    """A signal while the runner is being built (the run directory claimed, no handler of
    the run's yet): the run stops before its first stage (exit 130, status stopped), and
    resume runs it whole."""
    d = tmp_path / "run"
    p = child(scan, d, "ares.scan.runner:Runner.__init__", "SIGTERM", 1)
    assert p.returncode == 130, p.stderr
    assert json.loads((d / "run.json").read_text())["status"] == "stopped"
    check_truthful_then_resume(d, p, reference)


# ---------------------------------------------------------------- the sweep (study)


def _load(n: int) -> list[subprocess.Popen]:
    """A load generator: ``n`` processes spinning on the CPU."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def _events(d: Path) -> list:
    """Events of the main job to start a delay from: each stage's JSON appearing, run.json
    saying the reports are being written."""
    def reports_writing():
        try:
            return json.loads((d / "run.json").read_text()).get("reports") == "writing"
        except (OSError, ValueError):
            return False

    return [("start", lambda: True)] + [(f"stage {k}", lambda k=k: (d / "stages" / f"{k:04d}.json").exists())
                                        for k in range(STAGES)] + [("reports", reports_writing)]


@pytest.mark.study
def test_sweep_under_load(scan, reference, tmp_path, report):
    """50 instants x SIGKILL/SIGTERM/SIGHUP over the main job (every stage, the window
    after the last, the reports) while every core is kept busy: each ends truthful and
    resume is identical."""
    rnd = random.Random(54)
    tally: dict[str, int] = {}
    load = _load(max(1, (os.cpu_count() or 2) // 2))  # (a shared machine: half its cores spinning)
    try:
        for i in range(50):
            sig = (signal.SIGKILL, signal.SIGTERM, signal.SIGHUP)[i % 3]
            d = tmp_path / f"run{i}"
            proc = subprocess.Popen([sys.executable, "-m", "ares.cli", "run", str(scan), "--out", str(d), "--quiet"],
                                    env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            name, ready = rnd.choice(_events(d))
            while not ready() and proc.poll() is None:
                time.sleep(0.005)
            time.sleep(rnd.uniform(0, 0.5))
            if proc.poll() is None:
                proc.send_signal(sig)
            out, err = proc.communicate()
            p = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
            key = f"{signal.Signals(sig).name} after {name.split()[0]}: exit {proc.returncode}"
            tally[key] = tally.get(key, 0) + 1
            if proc.returncode == 0:  # ended before the signal: nothing to check but the run
                assert effective_status(json.loads((d / "run.json").read_text()))[0] == "done"
                continue
            if not (d / "run.json").exists():  # before the run directory: nothing written
                assert proc.returncode in (-9, 130) and "Traceback" not in err, (name, err)
                continue
            check_truthful_then_resume(d, p, reference)
    finally:
        for q in load:
            q.kill()
            q.wait()
        report.append(f"signal sweep under load ({len(load)} spinning process(es)): "
                      + "; ".join(f"{k} x{n}" for k, n in sorted(tally.items())))
