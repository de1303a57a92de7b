"""The results database on SQLAlchemy Core and Alembic: URLs and plain paths, the migrated
schema equal to the tables the queries use (SQLite and a real PostgreSQL), a database the
pre-Alembic layer wrote upgraded with its rows, two `ares batch` processes appending to one new
database at the same instant losing nothing, and
every damaged, locked, read-only or unreachable database one sentence naming it."""

from __future__ import annotations

import os
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from ares.batch import db as rdb
from ares.batch import dbconn
from ares.cli import main
from tests.test_lots import _lot, postgres  # noqa: F401 -- the PostgreSQL fixture

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def scheduler():
    """One real Dask scheduler with one worker for the module's ``ares batch`` runs."""
    pytest.importorskip("distributed")
    from ares.batch.cluster import close_client, make_client

    c = make_client(workers=1)
    yield c.scheduler.address
    close_client(c)

# the DDL the hand-written DB-API layer (schema 1, before Alembic) ran on a new database
LEGACY = ("CREATE TABLE ares_schema (version INTEGER NOT NULL)",
          "INSERT INTO ares_schema (version) VALUES (1)",
          "CREATE TABLE lots (lot_id INTEGER PRIMARY KEY, name TEXT NOT NULL, created TEXT NOT NULL, "
          "ares_version TEXT NOT NULL, n_items INTEGER NOT NULL, limits_set INTEGER NOT NULL)",
          "CREATE TABLE items (lot_id INTEGER NOT NULL REFERENCES lots(lot_id), idx INTEGER NOT NULL, "
          "item TEXT NOT NULL, serial TEXT, wafer TEXT, x DOUBLE PRECISION, y DOUBLE PRECISION, kind TEXT, "
          "status TEXT NOT NULL, verdict TEXT NOT NULL, error TEXT, run_dir TEXT, content_hash TEXT, "
          "ares_version TEXT, started TEXT, PRIMARY KEY (lot_id, idx))",
          "CREATE TABLE figures (lot_id INTEGER NOT NULL, idx INTEGER NOT NULL, quantity TEXT NOT NULL, "
          "value DOUBLE PRECISION, se DOUBLE PRECISION, unit TEXT, verdict TEXT, PRIMARY KEY (lot_id, idx, quantity))",
          "CREATE TABLE checks (lot_id INTEGER NOT NULL, idx INTEGER NOT NULL, limit_text TEXT NOT NULL, "
          "outcome TEXT NOT NULL, PRIMARY KEY (lot_id, idx, limit_text))",
          "CREATE INDEX figures_quantity ON figures (quantity)",
          "INSERT INTO lots VALUES (1, 'old', '2026-01-01T00:00:00+00:00', '0.0.9', 1, 1)",
          "INSERT INTO items (lot_id, idx, item, serial, status, verdict, x, y) "
          "VALUES (1, 0, '/a/die', 'SN1', 'done', 'pass', 1.5, 2.5)",
          "INSERT INTO figures VALUES (1, 0, 'gain_dn_per_e', 0.3, 0.001, 'DN/e-', 'ok')",
          "INSERT INTO checks VALUES (1, 0, 'gain_dn_per_e >= 0.28', 'pass')")


def _schema_diff(target: str) -> list:
    import sqlalchemy as sa
    from alembic.autogenerate import compare_metadata
    from alembic.runtime.migration import MigrationContext

    from ares.batch.dbschema import metadata

    eng = sa.create_engine(dbconn.url_of(target))
    try:
        with eng.connect() as c:
            return compare_metadata(MigrationContext.configure(c), metadata)
    finally:
        eng.dispose()


def test_migrated_sqlite_is_the_schema_the_queries_use_and_a_url_is_a_url(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with rdb.connect("sqlite:///results/lots.db") as db:
        assert rdb.version(db) == rdb.SCHEMA_VERSION == 3
        rdb.append_lot(db, "w1", _lot(40))
    assert (tmp_path / "results" / "lots.db").is_file() and not (tmp_path / "sqlite:").exists()
    assert _schema_diff("results/lots.db") == []  # a plain path is the same SQLite file
    with rdb.connect(str(tmp_path / "results" / "lots.db")) as db:
        assert rdb.lots(db)[0]["items"] == 40


def test_migrated_postgresql_is_the_schema_the_queries_use(postgres):  # noqa: F811
    url = postgres.replace("postgresql://", "postgresql+psycopg://", 1)
    with rdb.connect(url) as db:
        assert rdb.version(db) == rdb.SCHEMA_VERSION
    assert _schema_diff(url) == []


def _fresh_pg_database(uri: str, name: str) -> str:
    import psycopg

    with psycopg.connect(uri, autocommit=True) as c:
        c.execute(f"DROP DATABASE IF EXISTS {name}")
        c.execute(f"CREATE DATABASE {name}")
    return uri.replace("/postgres?", f"/{name}?", 1)


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_a_pre_alembic_database_is_upgraded_with_its_rows(backend, tmp_path, request):
    if backend == "sqlite":
        target = str(tmp_path / "old.sqlite")
        c = sqlite3.connect(target)
    else:
        import psycopg

        target = _fresh_pg_database(request.getfixturevalue("postgres"), "ares_legacy")
        c = psycopg.connect(target)
    for stmt in LEGACY:  # (the old layer ran this same DDL on both)
        c.execute(stmt)
    c.commit()
    c.close()
    with rdb.connect(target) as db:
        assert rdb.version(db) == rdb.SCHEMA_VERSION
        cols, rows = rdb.item_rows(db, rdb.find_lot(db, "old"))
        r = dict(zip(cols, rows[0]))
        assert (r["serial"], r["x"], r["gain_dn_per_e"], r["gain_dn_per_e >= 0.28"]) == ("SN1", 1.5, 0.3, "pass")
        assert r["hard_bin"] is None  # a column added by the upgrade: empty for the old lot
        assert rdb.append_lot(db, "new", _lot(10)) == 2
        assert rdb.bins(db, 1) == {}  # (a table added by the upgrade)
    import sqlalchemy as sa

    eng = sa.create_engine(dbconn.url_of(target))
    with eng.connect() as c:
        assert c.execute(sa.text("SELECT version FROM ares_schema")).all() == [(3,)]  # an older ARES refuses it now
        assert c.execute(sa.text("SELECT version_num FROM alembic_version")).all() == [("0003",)]
    eng.dispose()


BATCH = """
import sys, time
from pathlib import Path
sys.path.insert(0, {root!r})
from ares.batch import db as rdb
real, ready, go = rdb.append_lot, Path(sys.argv[1] + ".ready"), Path({go!r})


def append_at_the_same_time(*a, **k):  # both processes reach the append, then both go at once
    ready.touch()
    while not go.exists():
        time.sleep(0.005)
    return real(*a, **k)


rdb.append_lot = append_at_the_same_time
from ares.batch import lot_pdf
lot_pdf.write_pdf = lambda j, path, name: Path(path).write_bytes(b"")  # (the pages: not this test's concern)
from ares.cli import main
sys.exit(main(["batch", "--lot", sys.argv[1], "--out", sys.argv[2], "--db", {target!r}, "--scheduler", {sched!r},
               "-q"]))
"""


def _two_lots(tmp_path, n: int = 3) -> dict[str, list[str]]:
    """Two lot files (A, B) of ``n`` tiny dark stacks each; {lot: its serials}."""
    import numpy as np

    rng = np.random.default_rng(11)
    out = {}
    for lot in "AB":
        (tmp_path / lot).mkdir()
        serials = [f"{lot}{i}" for i in range(n)]
        for s in serials:
            np.save(tmp_path / lot / f"{s}.npy", (200 + rng.normal(0, 3, (3, 8, 8))).astype(np.uint16))
        items = "".join(f'<item path="{lot}/{s}.npy" sensor="{s}"/>' for s in serials)
        (tmp_path / f"{lot}.xml").write_text(f'<lot name="lot_{lot}" version="1">{items}</lot>')
        out[f"lot_{lot}"] = serials
    return out


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_two_ares_batch_processes_into_one_database_lose_nothing(backend, tmp_path, request, scheduler):
    """Two ``ares batch`` processes on one scheduler, into one new database (both create its
    schema at once), their appends released at the same instant: both lots whole, every item
    once, no "database is locked". (Cheap: three 3 x 8 x 8 stacks a lot, and lot.pdf's
    rendering -- most of a small lot's CPU, nothing of the database's -- left out.)"""
    if backend == "sqlite":
        target = f"sqlite:///{tmp_path}/r.sqlite"
    else:
        target = _fresh_pg_database(request.getfixturevalue("postgres"), "ares_writers")
    lots = _two_lots(tmp_path)
    go = tmp_path / "go"
    code = BATCH.format(root=str(ROOT), go=str(go), target=target, sched=scheduler)
    procs = [subprocess.Popen([sys.executable, "-c", code, str(tmp_path / f"{x}.xml"), str(tmp_path / f"out{x}")],
                              cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for x in "AB"]
    try:
        deadline = time.monotonic() + 900  # (minutes: two interpreters starting on a loaded machine)
        while not all((tmp_path / f"{x}.xml.ready").exists() for x in "AB"):
            assert all(p.poll() is None for p in procs), [p.communicate() for p in procs]
            assert time.monotonic() < deadline
            time.sleep(0.02)
        go.touch()
        outs = [p.communicate(timeout=900) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    assert [p.returncode for p in procs] == [0, 0], outs
    assert all("locked" not in e and "Traceback" not in e for _, e in outs), outs
    with rdb.connect(target) as db:
        got = rdb.lots(db)
        assert sorted(r["name"] for r in got) == sorted(lots) and sorted(r["lot_id"] for r in got) == [1, 2]
        for r in got:
            cols, rows = rdb.item_rows(db, r["lot_id"])
            serials = [dict(zip(cols, row))["serial"] for row in rows]
            assert sorted(serials) == lots[r["name"]] and r["items"] == 3  # every item once
            assert all(rdb.figures(db, r["lot_id"])[i] for i in range(3))  # with its figures


def test_a_lock_is_waited_for_within_the_timeout_then_one_sentence(tmp_path, monkeypatch, capsys):
    path = tmp_path / "r.sqlite"
    with rdb.connect(str(path)) as db:
        rdb.append_lot(db, "w1", _lot(5))
    holder = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    holder.execute("BEGIN EXCLUSIVE")  # another process's long write
    released = threading.Event()

    def release():
        released.wait()
        holder.execute("COMMIT")

    th = threading.Thread(target=release)
    th.start()
    try:
        monkeypatch.setattr(dbconn, "LOCK_TIMEOUT_S", 20.0)
        threading.Timer(0.3, released.set).start()
        with rdb.connect(str(path)) as db:  # waits for the lock, then appends
            assert rdb.append_lot(db, "w2", _lot(5)) == 2
    finally:
        released.set()
        th.join()
    holder.execute("BEGIN EXCLUSIVE")
    try:
        monkeypatch.setattr(dbconn, "LOCK_TIMEOUT_S", 0.2)
        for argv in (["lots", "list"], ["lots", "export", "w1"]):
            assert main([*argv, "--db", str(path)]) == 5
            err = capsys.readouterr().err
            assert f"results database {path}: locked by another writer for more than 0.2 s" in err, err
            assert "Traceback" not in err and err.count("\n") == 1
    finally:
        holder.execute("ROLLBACK")
        holder.close()


def test_damaged_read_only_and_unreachable_databases_are_one_sentence(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.sqlite"
    bad.write_bytes(os.urandom(4096))
    assert main(["lots", "list", "--db", str(bad)]) == 5
    err = capsys.readouterr().err
    assert f"results database {bad}: damaged" in err and "move it aside" in err and err.count("\n") == 1
    ok = tmp_path / "ok.sqlite"
    with rdb.connect(str(ok)) as db:
        rdb.append_lot(db, "w1", _lot(5))
    ro = f"sqlite:///file:{ok}?mode=ro&uri=true"
    with pytest.raises(dbconn.ResultsDbError, match="cannot be written .*readonly.*give --db a file in a writable"):
        with rdb.connect(ro) as db:
            rdb.append_lot(db, "w2", _lot(5))
    with rdb.connect(str(ok)) as db:  # nothing of the failed append is in it
        assert [r["name"] for r in rdb.lots(db)] == ["w1"]
    assert not (tmp_path / "file:").exists()  # (a URI filename names the file; no folder "file:" made)
    assert main(["lots", "list", "--db", "postgresql://ares@127.0.0.1:1/lots"]) == 5
    err = capsys.readouterr().err
    assert "results database postgresql+psycopg://ares@127.0.0.1:1/lots: unreachable" in err and err.count("\n") == 1
    (tmp_path / "afile").write_text("x")
    with pytest.raises(dbconn.ResultsDbError, match="cannot be written"):
        with rdb.connect(str(tmp_path / "afile" / "r.sqlite")):
            pass


def test_ares_batch_says_an_unusable_database_before_the_work(tmp_path, capsys):
    import numpy as np

    np.save(tmp_path / "d.npy", np.zeros((2, 4, 4), np.uint16))
    bad = tmp_path / "bad.sqlite"
    bad.write_bytes(b"\x00garbage" * 512)
    out = tmp_path / "lot"
    assert main(["batch", str(tmp_path / "d.npy"), "--out", str(out), "--db", str(bad), "-q"]) == 5
    err = capsys.readouterr().err
    assert err.startswith(f"ares batch: results database {bad}: damaged") and err.count("\n") == 1
    assert not (out / "lot.csv").exists()  # said before any work (no cluster started)


def test_a_lock_held_past_the_timeout_at_the_append_keeps_the_lot_files(tmp_path, capsys, monkeypatch, scheduler):
    """Another writer holds the database when the lot is appended (after the work): one
    sentence naming the database, the lot files written, the database without the lot."""
    import numpy as np

    np.save(tmp_path / "d.npy", (200 + np.arange(2 * 8 * 8).reshape(2, 8, 8) % 7).astype(np.uint16))
    path = tmp_path / "r.sqlite"
    real = rdb.append_lot
    holder = []

    def append_while_locked(db, name, judged):
        c = sqlite3.connect(path, isolation_level=None)
        c.execute("BEGIN EXCLUSIVE")  # another process's write, held past the timeout
        holder.append(c)
        return real(db, name, judged)

    monkeypatch.setattr(rdb, "append_lot", append_while_locked)
    monkeypatch.setattr(dbconn, "LOCK_TIMEOUT_S", 0.2)
    try:
        out = tmp_path / "lot"
        rc = main(["batch", str(tmp_path / "d.npy"), "--out", str(out), "--db", str(path), "-q",
                   "--scheduler", scheduler])
    finally:
        for c in holder:
            c.execute("ROLLBACK")
            c.close()
    err = capsys.readouterr().err
    assert rc == 5 and err.count("\n") == 1 and "Traceback" not in err
    assert f"results database {path}: locked by another writer for more than 0.2 s" in err
    assert "the lot is not in it, its files are" in err
    assert all((out / f).is_file() for f in ("lot.csv", "lot.h5", "lot.pdf", "lot.stdf"))
    with rdb.connect(str(path)) as db:
        assert rdb.lots(db) == []
