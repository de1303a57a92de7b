"""Integrity of every file a run wrote (``ares.rundir.manifest``): a ``report.h5`` overwritten
in the middle with 4 KB of garbage (same size, valid-looking) is named by ``ares report``
(which says it writes it anew), ``ares rerun``, ``ares batch`` and ``ares batch --rerun``;
files of the run itself missing or altered are all named at once, and nothing is reported
from them. One tiny simulated run (24x32, 4 frames)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from ares.cli import main

pytest.importorskip("distributed")

from test_report import PTC, SCAN, tiny_system  # noqa: E402
from test_run_integrity import scheduler  # noqa: E402,F401 -- a 1-worker cluster


def _garble_middle(p: Path, n: int = 4096) -> None:
    size = p.stat().st_size
    assert size > 2 * n
    with open(p, "r+b") as fh:
        fh.seek(size // 2 - n // 2)
        fh.write(os.urandom(n))
    assert p.stat().st_size == size


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    base = tmp_path_factory.mktemp("manifest")
    system = tiny_system(base / "sim_tiny.xml")
    xml = base / "ptc_tiny.xml"
    xml.write_text(SCAN.format(system=system.name, **dict(PTC, extra='<output pdf="false" csv="false"/>')))
    d = base / "good"
    assert main(["run", str(xml), "--out", str(d), "--seed", "3", "-q"]) == 0
    assert main(["report", str(d), "--hdf5", str(d / "report.h5")]) == 0
    return d


def _copy(good: Path, tmp_path: Path, name: str) -> Path:
    d = tmp_path / name
    shutil.copytree(good, d)
    (d / ".ares-claim").unlink(missing_ok=True)
    return d


def test_the_manifest_records_every_file_the_run_and_its_report_wrote(good):
    from ares.rundir import manifest

    files = json.loads((good / manifest.MANIFEST).read_text())["files"]
    on_disk = {str(p.relative_to(good)) for p in good.rglob("*") if p.is_file()} - {"run.json", "manifest.json",
                                                                                     ".ares-claim"}
    assert set(files) == on_disk
    assert files["report.h5"]["by"] == "report" and files["results.h5"]["by"] == "run"
    assert {"stages/0002.h5", "stages/0002.json", "results.h5", "scan_results.json"} <= set(files)
    assert any(k.startswith("xml/") for k in files)
    assert manifest.problems(good) == []


def test_a_garbled_report_h5_is_named_and_written_anew_by_ares_report(good, tmp_path, capsys):
    from ares.rundir import manifest

    d = _copy(good, tmp_path, "garbled")
    _garble_middle(d / "report.h5")
    assert manifest.problems(d) == [("report.h5", "altered (its SHA-256 differs from the one recorded when it "
                                                  "was written)")]
    assert main(["report", str(d), "--hdf5", str(d / "report.h5")]) == 0
    err = capsys.readouterr().err
    assert f"note: {d / 'report.h5'} was altered after ARES wrote it (its SHA-256 differs" in err
    assert "written anew now" in err
    assert manifest.problems(d) == []  # the new report.h5 recorded


def test_rerun_and_batch_name_a_garbled_report_h5(good, tmp_path, scheduler, capsys):  # noqa: F811
    d = _copy(good, tmp_path, "garbled")
    _garble_middle(d / "report.h5")
    want = f"{d}: not as written: report.h5 altered (its SHA-256 differs"
    assert main(["rerun", str(d), "--out", str(tmp_path / "again"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "reproduced: 10 of 10" in err and f"original run: {want}" in err
    for extra in ((), ("--rerun",)):
        assert main(["batch", str(d), "--out", str(tmp_path / f"lot{len(extra)}"), "--scheduler", scheduler,
                     "--no-db", "-q", *extra]) == 1
        err = capsys.readouterr().err
        assert want in err and "Traceback" not in err, err
    assert "16/16" not in err and "10 of 10 stage(s) and their arrays reproduce" in err


def test_every_missing_or_altered_run_file_is_named_and_nothing_is_reported(good, tmp_path, capsys):
    d = _copy(good, tmp_path, "several")
    (d / "report.h5").unlink()  # (a report: written again, not an error)
    _garble_middle(d / "results.h5", 16)
    with open(d / "scan_results.json", "a") as fh:
        fh.write(" ")
    assert main(["report", str(d), "--hdf5", str(d / "again.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "scan_results.json altered (" in err and "results.h5 altered (its SHA-256" in err
    assert "report.h5" not in err and not (d / "again.h5").exists()


def test_resume_names_altered_reports_and_never_re_blesses_them(good, tmp_path, capsys):
    """An interrupted run (its report.h5 written at the interruption, an extra report written
    into it by `ares report`), both reports garbled before `ares resume`: the resume names
    each -- report.h5 written anew, the extra one left as found and still recorded as
    altered (the resume's new manifest does not take it as the run's own). An altered file
    of the run itself (results.h5) refuses the resume, naming it."""
    from ares.rundir import manifest

    d = tmp_path / "cut"
    assert main(["run", str(good.parent / "ptc_tiny.xml"), "--out", str(d), "--seed", "3", "-q",
                 "--sim-fault", "disconnect_after_frames=13"]) == 3
    assert main(["report", str(d), "--hdf5", str(d / "extra.h5")]) == 0
    edited = _copy(d, tmp_path, "edited")
    _garble_middle(edited / "results.h5", 16)
    for p in (d / "report.h5", d / "extra.h5"):
        _garble_middle(p)
    capsys.readouterr()
    assert main(["resume", str(edited), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"{edited}: not as written: results.h5 altered (its SHA-256" in err and "a resume would continue" in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert main(["resume", str(d), "-q"]) == 0
    err = capsys.readouterr().err
    assert f"note: {d / 'report.h5'} was altered after ARES wrote it (its SHA-256 differs" in err
    assert "written anew by the resume" in err
    assert f"note: {d / 'extra.h5'} was altered after ARES wrote it" in err and "still recorded as altered" in err
    assert manifest.problems(d) == [("extra.h5", "altered (its SHA-256 differs from the one recorded when it was "
                                                 "written)")]
    assert manifest.load(d)["extra.h5"]["by"] == manifest.REPORT
