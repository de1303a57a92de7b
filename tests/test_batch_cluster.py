"""``ares batch`` on a real Dask cluster: a scheduler and two workers started here as separate
processes (``dask scheduler`` / ``dask worker``, working directory elsewhere). Relative item
paths given on the client work and give the lot table of the same items analysed in the
test's own process; an item that fails on
a worker is one line naming it, never a traceback (``--stack`` too). The test waits on the
scheduler (its file, then its workers); the timeouts only catch a hang."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ares.cli import main

pytest.importorskip("distributed")

from test_report import PTC, SCAN, tiny_system  # noqa: E402

HANG = 300  # s: only a hung cluster gets here


def _dask(*args, cwd, env):
    exe = Path(sys.executable).with_name("dask")
    return subprocess.Popen([str(exe), *args], cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    from distributed import Client

    where = tmp_path_factory.mktemp("cluster")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).resolve().parents[1]),
                                                        os.environ.get("PYTHONPATH", "")])}
    sched_file = where / "scheduler.json"
    procs = [_dask("scheduler", "--host", "127.0.0.1", "--port", "0", "--dashboard-address", ":0",
                   "--scheduler-file", str(sched_file), cwd=where, env=env)]
    deadline = time.monotonic() + HANG
    while not sched_file.is_file():  # polling the scheduler's own announcement
        assert procs[0].poll() is None, "dask scheduler exited"
        assert time.monotonic() < deadline, "dask scheduler did not start"
        time.sleep(0.2)
    for _ in range(2):
        procs.append(_dask("worker", "--scheduler-file", str(sched_file), "--nthreads", "1", "--no-nanny",
                           "--no-dashboard", "--local-directory", str(where), cwd=where, env=env))
    client = Client(scheduler_file=str(sched_file), timeout=f"{HANG}s")
    client.wait_for_workers(2, timeout=HANG)
    yield client.scheduler.address
    client.close()
    for p in procs[:0:-1]:  # the workers (no nanny: one process each, no graceful close to wait for)
        p.kill()
    procs[0].terminate()
    for p in procs[::-1]:
        try:
            p.wait(timeout=HANG)
        except subprocess.TimeoutExpired:
            p.kill()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("lot")
    system = tiny_system(base / "sim_tiny.xml")
    xml = base / "ptc_tiny.xml"
    xml.write_text(SCAN.format(system=system.name, **dict(PTC, extra='<output pdf="false" csv="false"/>')))
    for i in range(2):
        assert main(["run", str(xml), "--out", str(base / f"s{i}"), "--seed", str(i), "-q"]) == 0
    bad = base / "bad"
    bad.mkdir()
    (bad / "run.json").write_text("{not json")
    return base


def _table(path: Path) -> list[dict]:
    skip = {"started", "lot"}  # the start time, and the lot named after its folder
    return [{k: v for k, v in r.items() if k not in skip} for r in csv.DictReader(path.open())]


def test_relative_paths_on_a_real_scheduler_equal_a_local_run(cluster, runs, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(runs)  # the client's working directory; the workers run in another one
    rc = main(["batch", "s0", "s1", "bad", "--out", str(tmp_path / "remote"), "--scheduler", cluster, "-q"])
    err = capsys.readouterr().err
    assert rc == 1  # the bad item, alone
    remote = _table(tmp_path / "remote" / "lot.csv")
    assert [r["status"] for r in remote] == ["done", "done", "error"]
    assert [r["item"] for r in remote] == [str(runs / n) for n in ("s0", "s1", "bad")]
    fails = [ln for ln in err.splitlines() if "FAILED" in ln]
    assert len(fails) == 1 and str(runs / "bad") in fails[0] and "Traceback" not in err
    # the same items analysed here, in this process, by the task the workers ran (no second
    # cluster to start): the same table -- figures, SEs, hashes
    import io

    from ares.batch.items import process
    from ares.batch.lot_report import judge, to_csv
    from ares.batch.screens import screen

    j = judge([process(str(runs / n)) for n in ("s0", "s1", "bad")], ())
    screen(j)
    local = [{k: v for k, v in r.items() if k not in {"started", "lot"}} for r in csv.DictReader(io.StringIO(to_csv(j)))]
    assert remote == local
    assert float(remote[0]["gain_dn_per_e"]) > 0 and remote[0]["gain_dn_per_e"] != remote[1]["gain_dn_per_e"]
    # the lot is in the default results database, and its log names every item
    log = (tmp_path / "remote" / "lot.log").read_text()
    assert "3/3 done, 1 failed" in log and (tmp_path / "remote" / "results.sqlite").is_file()


def test_stack_error_is_one_line(cluster, runs, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(runs)
    (runs / "notastack.npy").write_bytes(b"this is not a numpy file")
    assert main(["batch", "--stack", "notastack.npy", "--scheduler", cluster, "-q"]) == 2
    err = capsys.readouterr().err
    assert "notastack.npy" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
