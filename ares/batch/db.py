"""The results database: every lot item's key figures, SEs, verdicts, limit outcomes and
traceability, appended lot by lot.

SQLite by default (embedded, one file, nothing to start); PostgreSQL when the target is a
``postgresql://`` URL (through ``psycopg`` 3). Plain DB-API, one schema for both: the same
tables, the same rows; ``SCHEMA_VERSION`` is kept in ``ares_schema`` and ``MIGRATIONS`` brings
an older database up to it when it is opened.

Tables: ``lots`` (one row a lot), ``items`` (one row an item: serial, wafer, x/y, run
directory, content hash, ARES version, start time, status, verdict, error), ``figures``
(item x quantity: canonical name, value, SE, unit, verdict) and ``checks`` (item x limit:
pass / FAIL / not tested).
"""

from __future__ import annotations

import contextlib
import datetime

SCHEMA_VERSION = 1
# version -> the statements that bring a database from version - 1 to it
MIGRATIONS: dict[int, tuple[str, ...]] = {
    1: (
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
    ),
}
ITEM_COLUMNS = ("item", "serial", "wafer", "x", "y", "kind", "status", "verdict", "error", "run_dir",
                "content_hash", "ares_version", "started")


class Db:
    """A DB-API connection and its parameter marker (``?`` sqlite3, ``%s`` psycopg)."""

    def __init__(self, conn, mark: str, target: str):
        self.conn, self.mark, self.target = conn, mark, target

    def sql(self, text: str) -> str:
        return text.replace("?", self.mark)

    def execute(self, text: str, params=()):
        cur = self.conn.cursor()
        cur.execute(self.sql(text), params)
        return cur

    def executemany(self, text: str, rows) -> None:
        cur = self.conn.cursor()
        cur.executemany(self.sql(text), rows)

    def query(self, text: str, params=()) -> list[tuple]:
        return [tuple(r) for r in self.execute(text, params).fetchall()]


@contextlib.contextmanager
def connect(target: str):
    """The database at ``target`` (a file path: SQLite; ``postgresql://``: PostgreSQL), at
    ``SCHEMA_VERSION``; committed on leaving, rolled back on an exception."""
    from ares.errors import InputError

    if target.startswith(("postgresql://", "postgres://")):
        try:
            import psycopg
        except ImportError:
            raise InputError(f"{target}: PostgreSQL needs the psycopg package (pip install 'psycopg[binary]')") \
                from None
        try:
            conn = psycopg.connect(target)
        except psycopg.Error as exc:
            raise InputError(f"results database {target}: cannot connect ({' '.join(str(exc).split())})") from None
        db = Db(conn, "%s", target)
    else:
        import sqlite3
        from pathlib import Path

        Path(target).parent.mkdir(parents=True, exist_ok=True)
        try:
            conn = sqlite3.connect(target)
            conn.execute("PRAGMA foreign_keys = ON")
        except sqlite3.Error as exc:
            raise InputError(f"results database {target}: {exc}") from None
        db = Db(conn, "?", target)
    try:
        migrate(db)
        yield db
        conn.commit()
    except BaseException:
        conn.rollback()
        raise
    finally:
        conn.close()


def version(db: Db) -> int:
    try:
        rows = db.query("SELECT version FROM ares_schema")
    except Exception:  # noqa: BLE001 -- no such table: an empty database (sqlite3/psycopg raise their own types)
        db.conn.rollback()
        return 0
    return int(rows[0][0]) if rows else 0


def migrate(db: Db) -> int:
    """Apply the migrations the database lacks; its version afterwards."""
    from ares.errors import InputError

    v = version(db)
    if v > SCHEMA_VERSION:
        raise InputError(f"results database {db.target}: schema version {v} is newer than this ARES "
                         f"({SCHEMA_VERSION}); update ARES")
    if v == 0:
        db.execute("CREATE TABLE ares_schema (version INTEGER NOT NULL)")
        db.execute("INSERT INTO ares_schema (version) VALUES (0)")
    for n in range(v + 1, SCHEMA_VERSION + 1):
        for stmt in MIGRATIONS[n]:
            db.execute(stmt)
        db.execute("UPDATE ares_schema SET version = ?", (n,))
    db.conn.commit()
    return SCHEMA_VERSION


def _num(v):
    return None if v is None else float(v)


def append_lot(db: Db, name: str, judged) -> int:
    """Append a judged lot (``lot_report.judge``); its ``lot_id``."""
    from ares import __version__
    from ares.batch.lot_report import rows

    data, _ = rows(judged, name)
    lot_id = (db.query("SELECT COALESCE(MAX(lot_id), 0) FROM lots")[0][0] or 0) + 1
    created = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    db.execute("INSERT INTO lots (lot_id, name, created, ares_version, n_items, limits_set) VALUES (?, ?, ?, ?, ?, ?)",
               (lot_id, name, created, __version__, len(data), int(bool(judged.limits))))
    marks = ", ".join("?" * (len(ITEM_COLUMNS) + 2))
    db.executemany(f"INSERT INTO items (lot_id, idx, {', '.join(ITEM_COLUMNS)}) VALUES ({marks})",
                   [(lot_id, i, *(_num(row[c]) if c in ("x", "y") else str(row[c] or "") for c in ITEM_COLUMNS))
                    for i, row in enumerate(data)])
    figs, checks = [], []
    for i, r in enumerate(judged.results):
        for q, f in (r.get("figures") or {}).items():
            figs.append((lot_id, i, q, _num(f.get("value")), _num(f.get("se")), f.get("unit") or "",
                         f.get("verdict") or ""))
        for k in judged.yields:
            checks.append((lot_id, i, k, data[i].get(k) or ""))
    db.executemany("INSERT INTO figures (lot_id, idx, quantity, value, se, unit, verdict) VALUES (?, ?, ?, ?, ?, ?, ?)",
                   figs)
    db.executemany("INSERT INTO checks (lot_id, idx, limit_text, outcome) VALUES (?, ?, ?, ?)", checks)
    return lot_id


def lots(db: Db) -> list[dict]:
    """Every lot with its item counts and overall yield (passed / items, errored included)."""
    out = []
    for lot_id, name, created, ver, n, limited in db.query(
            "SELECT lot_id, name, created, ares_version, n_items, limits_set FROM lots ORDER BY lot_id"):
        counts = dict(db.query("SELECT verdict, COUNT(*) FROM items WHERE lot_id = ? GROUP BY verdict", (lot_id,)))
        out.append({"lot_id": lot_id, "name": name, "created": created, "ares_version": ver, "items": n,
                    "passed": counts.get("pass", 0), "failed": counts.get("FAIL", 0), "errors": counts.get("error", 0),
                    "limits_set": bool(limited)})
    return out


def find_lot(db: Db, ref: str) -> int:
    """A lot by id or name (the newest of that name)."""
    from ares.errors import InputError

    rows = db.query("SELECT lot_id FROM lots WHERE name = ? ORDER BY lot_id DESC", (ref,))
    if not rows and ref.isdigit():
        rows = db.query("SELECT lot_id FROM lots WHERE lot_id = ?", (int(ref),))
    if not rows:
        raise InputError(f"results database {db.target}: no lot '{ref}' (ares lots list shows them)")
    return int(rows[0][0])


NUMERIC_ITEM_COLUMNS = ("x", "y")


def quantities(db: Db, lot_id: int) -> list[str]:
    """The canonical names of the quantities measured in a lot, sorted."""
    return [r[0] for r in db.query("SELECT DISTINCT quantity FROM figures WHERE lot_id = ? ORDER BY quantity",
                                   (lot_id,))]


def numeric_columns(db: Db, lot_id: int) -> set[str]:
    """The columns of ``item_rows`` that hold numbers (wafer x/y, each quantity and its SE);
    the others are text."""
    return set(NUMERIC_ITEM_COLUMNS) | {c for q in quantities(db, lot_id) for c in (q, f"{q}_se")}


def item_rows(db: Db, lot_id: int) -> tuple[list[str], list[tuple]]:
    """The lot's items, one row each: the traceability columns, then value and SE of every
    quantity (sorted by name), then every limit's outcome."""
    items = db.query(f"SELECT idx, {', '.join(ITEM_COLUMNS)} FROM items WHERE lot_id = ? ORDER BY idx", (lot_id,))
    qs = quantities(db, lot_id)
    ls = [r[0] for r in db.query("SELECT DISTINCT limit_text FROM checks WHERE lot_id = ? ORDER BY limit_text",
                                 (lot_id,))]
    figs = {(i, q): (v, s) for i, q, v, s in db.query("SELECT idx, quantity, value, se FROM figures WHERE lot_id = ?",
                                                      (lot_id,))}
    chk = {(i, k): o for i, k, o in db.query("SELECT idx, limit_text, outcome FROM checks WHERE lot_id = ?", (lot_id,))}
    cols = list(ITEM_COLUMNS) + [c for q in qs for c in (q, f"{q}_se")] + ls
    out = []
    for idx, *rest in items:
        row = list(rest)
        for q in qs:
            row += list(figs.get((idx, q), (None, None)))
        row += [chk.get((idx, k), "") for k in ls]
        out.append(tuple(row))
    return cols, out


def quantity_stats(db: Db, lot_id: int) -> dict[str, tuple[int, float | None, float | None]]:
    """Quantity -> (items measured, median, IQR) in a lot (computed here: portable SQL)."""
    import numpy as np

    vals: dict[str, list[float]] = {}
    for q, v in db.query("SELECT quantity, value FROM figures WHERE lot_id = ? AND value IS NOT NULL", (lot_id,)):
        vals.setdefault(q, []).append(float(v))
    out = {}
    for q, vs in sorted(vals.items()):
        a = np.asarray(vs)
        p25, p50, p75 = np.percentile(a, [25, 50, 75])
        out[q] = (len(vs), float(p50), float(p75 - p25))
    return out
