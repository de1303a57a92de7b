"""Integrity of a run directory (``ares.rundir.check``): a corrupt array, a deleted stage and a
truncated HDF5 are each reported as such -- one sentence naming the stage and the file, a
non-zero exit, no figures -- by ``ares report``, ``ares batch`` and ``ares batch --rerun``;
before the content hashes, the first two came out as a full report (exit 0) and ``--rerun``
said "10/10 reproduced". One tiny simulated run (24x32, 4 frames), damaged three ways."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from ares.cli import main

pytest.importorskip("distributed")

from test_report import PTC, SCAN, tiny_system  # noqa: E402

STAGE = "0002"


def _flip_array_bytes(h5: Path, name: str) -> None:
    """Flip the bits of 4 bytes inside the (contiguous, uncompressed) dataset ``name`` in
    place: the file stays valid HDF5, only the array's values change."""
    import h5py

    with h5py.File(h5, "r") as f:
        offset = f[name].id.get_offset()
    assert offset is not None
    with open(h5, "r+b") as fh:
        fh.seek(offset + 8)
        b = fh.read(4)
        fh.seek(offset + 8)
        fh.write(bytes(x ^ 0xFF for x in b))


@pytest.fixture(scope="module")
def damaged(tmp_path_factory):
    """{damage: run directory}: the intact run and three copies, each damaged one way."""
    base = tmp_path_factory.mktemp("integrity")
    system = tiny_system(base / "sim_tiny.xml")
    xml = base / "ptc_tiny.xml"
    xml.write_text(SCAN.format(system=system.name, **dict(PTC, extra='<output pdf="false" csv="false"/>')))
    good = base / "good"
    assert main(["run", str(xml), "--out", str(good), "--seed", "3", "-q"]) == 0
    out = {"good": good, "xml": xml}
    for damage in ("corrupt array", "deleted stage", "truncated hdf5"):  # (keys of EXPECT)
        d = base / damage.replace(" ", "_")
        shutil.copytree(good, d)
        h5 = d / "stages" / f"{STAGE}.h5"
        if damage == "corrupt array":
            _flip_array_bytes(h5, "mean")
        elif damage == "deleted stage":
            (d / "stages" / f"{STAGE}.json").unlink()
            h5.unlink()
        else:
            h5.write_bytes(h5.read_bytes()[: h5.stat().st_size // 2])
        out[damage] = d
    return out


@pytest.fixture(scope="module")
def scheduler():
    """A 1-worker local Dask cluster that ``ares batch --scheduler`` connects to."""
    from ares.batch.cluster import make_client

    c = make_client(workers=1)
    yield c.scheduler.address
    c.close()
    c.cluster.close()


EXPECT = {
    "corrupt array": f"corrupt: stage 2 ('ptc[1]'): array 'mean' of stages/{STAGE}.h5 differs from the SHA-256 "
                     "recorded when it was written",
    "deleted stage": f"incomplete: stage 2 is missing (stages/{STAGE}.json, recorded in run.json when it was "
                     "written, is gone)",
    "truncated hdf5": f"corrupt: stage 2 ('ptc[1]'): stages/{STAGE}.h5 is truncated (",
}


def _report(d: Path, capsys) -> str:
    assert main(["report", str(d)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and str(d) in err
    assert not (d / "key_figures.csv").exists()  # no figures from a damaged run
    return err


def _batch(d: Path, tmp_path: Path, scheduler: str, capsys, *extra: str) -> str:
    assert main(["batch", str(d), "--out", str(tmp_path / "lot"), "--scheduler", scheduler, "--no-db", "-q",
                 *extra]) == 1
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return cap.err


def _name_of_stage_2(damaged) -> str:
    return json.loads((damaged["good"] / "stages" / f"{STAGE}.json").read_text())["name"]


def test_expected_stage_name(damaged):
    """The sentences below name stage 2 of the PTC scan by its name (guards EXPECT)."""
    assert _name_of_stage_2(damaged) == "ptc[1]"


def test_intact_run_checks_clean_and_reruns_to_identical_arrays(damaged, tmp_path, capsys):
    """The intact run: ``ares report`` exits 0, and ``ares rerun`` reproduces every stage's
    results and every array's recorded SHA-256 (the simulator is exact)."""
    from ares.report import read_run

    read_run(damaged["good"], verify_arrays=True)
    assert main(["rerun", str(damaged["good"]), "--out", str(tmp_path / "again"), "-q"]) == 0
    assert "reproduced: 10 of 10 stage result(s) identical" in capsys.readouterr().err


# -- ares report -------------------------------------------------------------------

def test_report_names_a_corrupt_array(damaged, capsys):
    """stages/0002.h5 with 4 bytes of its 'mean' array flipped (still valid HDF5): `ares report` says corrupt: stage 2, array 'mean'."""
    assert EXPECT["corrupt array"] in _report(damaged["corrupt array"], capsys)


def test_report_names_a_deleted_stage(damaged, capsys):
    """stages/0002.json and stages/0002.h5 deleted: `ares report` says incomplete: stage 2 is missing."""
    assert EXPECT["deleted stage"] in _report(damaged["deleted stage"], capsys)


def test_report_names_a_truncated_hdf5(damaged, capsys):
    """stages/0002.h5 cut to half its size: `ares report` says corrupt: stage 2, the file truncated (bytes of bytes)."""
    assert EXPECT["truncated hdf5"] in _report(damaged["truncated hdf5"], capsys)


# -- ares batch ---------------------------------------------------------------------

def test_batch_names_a_corrupt_array(damaged, tmp_path, scheduler, capsys):
    """stages/0002.h5 with its 'mean' array's bytes flipped: `ares batch` fails the item (exit 1) saying corrupt: stage 2, array 'mean'."""
    assert EXPECT["corrupt array"] in _batch(damaged["corrupt array"], tmp_path, scheduler, capsys)


def test_batch_names_a_deleted_stage(damaged, tmp_path, scheduler, capsys):
    """stages/0002.json and .h5 deleted: `ares batch` fails the item (exit 1) saying incomplete: stage 2 is missing."""
    assert EXPECT["deleted stage"] in _batch(damaged["deleted stage"], tmp_path, scheduler, capsys)


def test_batch_names_a_truncated_hdf5(damaged, tmp_path, scheduler, capsys):
    """stages/0002.h5 cut to half: `ares batch` fails the item (exit 1) saying corrupt: stage 2, truncated."""
    assert EXPECT["truncated hdf5"] in _batch(damaged["truncated hdf5"], tmp_path, scheduler, capsys)


# -- ares batch --rerun -------------------------------------------------------------

def _rerun(damaged, damage, tmp_path, scheduler, capsys) -> str:
    err = _batch(damaged[damage], tmp_path, scheduler, capsys, "--rerun")
    # the rerun itself ran and matched what the original recorded when it was written
    assert "(its rerun " in err and "stage(s) and their arrays reproduce the recorded ones)" in err
    return err


def test_batch_rerun_names_a_corrupt_array(damaged, tmp_path, scheduler, capsys):
    """stages/0002.h5's 'mean' bytes flipped: `ares batch --rerun` no longer says 10/10 reproduced and exit 0 but fails the item: corrupt: stage 2, array 'mean'."""
    err = _rerun(damaged, "corrupt array", tmp_path, scheduler, capsys)
    assert EXPECT["corrupt array"] in err and "10 of 10 stage(s)" in err


def test_batch_rerun_names_a_deleted_stage(damaged, tmp_path, scheduler, capsys):
    """stages/0002.json and .h5 deleted: `ares batch --rerun` fails the item: incomplete: stage 2 is missing."""
    err = _rerun(damaged, "deleted stage", tmp_path, scheduler, capsys)
    assert EXPECT["deleted stage"] in err and "9 of 9 stage(s)" in err


def test_batch_rerun_names_a_truncated_hdf5(damaged, tmp_path, scheduler, capsys):
    """stages/0002.h5 cut to half: `ares batch --rerun` fails the item: corrupt: stage 2, truncated."""
    assert EXPECT["truncated hdf5"] in _rerun(damaged, "truncated hdf5", tmp_path, scheduler, capsys)


# -- the comparison names the array -------------------------------------------------

def test_rerun_comparison_names_the_stage_and_array_that_differ(damaged):
    """A rerun whose recorded hash of stage 2's 'variance' differs from the original's: the
    comparison names that stage and array (and counts the stage as not reproduced)."""
    from ares.rundir.compare import compare
    from ares.scan import load_run

    a = load_run(damaged["good"])
    b = load_run(damaged["good"])
    b.stages[2] = dict(b.stages[2], arrays_sha256=dict(b.stages[2]["arrays_sha256"], variance="0" * 64))
    same, n, diff = compare(a, b)
    assert (same, n) == (9, 10) and diff == ["stage 2 'ptc[1]': array variance"]


def test_hashes_are_of_the_array_values_not_the_file_layout():
    """The recorded hash is of dtype, shape and values: the same values hash alike whatever
    their memory layout, and one changed value or a different dtype changes it."""
    from ares.rundir.check import array_sha256

    a = np.arange(12, dtype=np.float32).reshape(3, 4)
    assert array_sha256(a) == array_sha256(np.asfortranarray(a)) == array_sha256(a.copy())
    b = a.copy()
    b[1, 2] += 1
    assert array_sha256(b) != array_sha256(a) != array_sha256(a.astype(np.float64))
    assert array_sha256(a) != array_sha256(a.reshape(4, 3))


def test_resume_records_a_stage_committed_just_before_the_kill(damaged, tmp_path, capsys):
    """A kill between a stage's JSON (the commit) and run.json leaves that stage without its
    recorded SHA-256: `ares resume` records it, so the finished run checks clean instead of
    reading as corrupt ("not written by this run")."""
    from ares.report import read_run

    d = tmp_path / "run"
    assert main(["run", str(damaged["xml"]), "--out", str(d), "--quiet", "--sim-fault", "disconnect_after_frames=13"]) == 3
    meta = json.loads((d / "run.json").read_text())
    last = max(meta["stage_sha256"])
    del meta["stage_sha256"][last]  # as if the kill came before run.json recorded it
    (d / "run.json").write_text(json.dumps(meta))
    assert main(["resume", str(d), "--quiet"]) == 0
    capsys.readouterr()
    meta = json.loads((d / "run.json").read_text())
    assert meta["status"] == "done" and last in meta["stage_sha256"]
    assert sorted(meta["stage_sha256"]) == sorted(p.stem for p in (d / "stages").glob("[0-9][0-9][0-9][0-9].json"))
    read_run(d, verify_arrays=True)  # (raises RunDamaged if any stage differs from its record)


def test_ares_rerun_reruns_but_names_a_corrupt_original(damaged, tmp_path, capsys):
    """stages/0002.h5's 'mean' bytes flipped: `ares rerun` still repeats the run (it needs only
    the verbatim XML), reports 10 of 10 stages reproduced against the recorded hashes, and
    ends with the original's one sentence, exit 2 -- it used to say only "reproduced", exit 0."""
    assert main(["rerun", str(damaged["corrupt array"]), "--out", str(tmp_path / "again"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "reproduced: 10 of 10 stage result(s) identical" in err
    assert f"original run: {damaged['corrupt array']}: {EXPECT['corrupt array']}" in err
