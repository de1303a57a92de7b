"""Recorded-data runs (issue 38): `ares validate` and `ares run` refuse a scan whose data
are missing before a run directory exists, and `ares rerun` / `ares resume` find the data
where the original run found them (run.json keeps the absolute path and the descriptor's
SHA-256), not below the run directory's verbatim copy of the system XML."""

from __future__ import annotations

import json

import numpy as np

from ares.cli import main
from test_replay_bench import _replay_system, _scan, _synthetic_set

EXPOSURES = " ".join(f"{t * 1e-9:.6g}" for t in np.linspace(1e5, 8e5, 8))
BODY = (f'<sweep name="ptc" scene="flat" dark="matched"><set quantity="light" value="2e6"/>'
        f'<axis quantity="exposure"><values>{EXPOSURES}</values></axis></sweep>')


def test_validate_and_run_refuse_missing_data_before_a_run_directory(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("ARES_TEST_REPLAY_UNSET", raising=False)
    sy = _replay_system(tmp_path, "nowhere/EMVA1288_Data.txt", rows=24, cols=32)
    sc = _scan(tmp_path, sy, BODY)
    assert main(["validate", str(sc)]) == 2  # said "valid" before
    err = capsys.readouterr().err
    assert f"{sy}:12: <replay> descriptor " in err and "not found" in err and err.count("\n") == 1
    out = tmp_path / "runs"
    assert main(["run", str(sc), "--out", str(out / "r"), "--quiet"]) == 2
    assert "not found" in capsys.readouterr().err
    assert not (out / "r").exists()  # no failed run directory left behind


def test_rerun_and_resume_find_the_data_where_the_run_found_it(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("ARES_TEST_REPLAY_UNSET", raising=False)
    _synthetic_set(tmp_path / "data", rows=24, cols=32)
    sy = _replay_system(tmp_path, "data/EMVA1288_Data.txt", rows=24, cols=32)
    sc = _scan(tmp_path, sy, BODY)
    sc.write_text(sc.read_text().replace("</scan>", '<output pdf="false"/>\n</scan>'))  # (no check reads a PDF)
    run = tmp_path / "run"
    assert main(["run", str(sc), "--out", str(run), "--quiet"]) == 0
    bench = json.loads((run / "run.json").read_text())["bench"]
    assert bench["replay_path"] == str(tmp_path / "data" / "EMVA1288_Data.txt") and len(bench["replay_sha256"]) == 64
    capsys.readouterr()
    monkeypatch.chdir(tmp_path / "data")  # from another folder: the run directory alone
    assert main(["rerun", str(run), "--out", str(tmp_path / "again"), "--quiet"]) == 0
    assert "reproduced: 8 of 8 stage result(s) identical" in capsys.readouterr().err
    # resume of a run cut short (its last stages taken out, status set back to stopped)
    cut = tmp_path / "again"
    for p in sorted((cut / "stages").glob("000[5-7].*")):
        p.unlink()
    meta = json.loads((cut / "run.json").read_text())
    meta["status"] = "stopped"
    (cut / "run.json").write_text(json.dumps(meta))
    assert main(["resume", str(cut), "--quiet"]) == 0
    assert json.loads((cut / "run.json").read_text())["status"] == "done"
    # data changed since the run: refused, naming the file
    desc = tmp_path / "data" / "EMVA1288_Data.txt"
    desc.write_text(desc.read_text() + "# edited\n")
    assert main(["rerun", str(run), "--out", str(tmp_path / "third"), "--quiet"]) == 2
    assert "changed since the run" in capsys.readouterr().err
