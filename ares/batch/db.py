"""The results database: every lot item's key figures, SEs, verdicts, bins, limit and screen
outcomes and traceability, appended lot by lot -- on SQLAlchemy Core, so one set of queries
serves SQLite (the default: embedded, one file), PostgreSQL and any database SQLAlchemy
has a dialect for; the schema and its upgrades are Alembic migrations.

Opening (URL or path, lock timeout, upgrade, one-sentence errors): ``ares.batch.dbconn``;
the tables: ``ares.batch.dbschema``. Here: appending a judged lot and reading lots back.
"""

from __future__ import annotations

import contextlib
import datetime

import sqlalchemy as sa

from ares.batch import dbschema as t
from ares.batch.dbconn import HEAD, SCHEMA_VERSION, Db, connect, revision, write_lock  # noqa: F401 -- the API

ITEM_COLUMNS = ("item", "serial", "wafer", "x", "y", "kind", "status", "verdict", "error", "run_dir",
                "content_hash", "ares_version", "started")
BIN_COLUMNS = ("hard_bin", "soft_bin")
NUMERIC_ITEM_COLUMNS = ("x", "y")


@contextlib.contextmanager
def _read(db: Db):
    """A read transaction (ended at once: a SQLite reader holds no lock afterwards)."""
    if db.conn.in_transaction():
        yield db.conn
        return
    with db.conn.begin():
        yield db.conn


def _rows(db: Db, stmt) -> list[tuple]:
    with _read(db) as c:
        return [tuple(r) for r in c.execute(stmt).all()]


def version(db: Db) -> int:
    with _read(db) as c:
        rev = revision(c)
    return 0 if rev is None else int(rev)


def _num(v):
    return None if v is None else float(v)


def append_lot(db: Db, name: str, judged) -> int:
    """Append a judged lot (``lot_report.judge``) in one transaction under the write lock;
    its ``lot_id`` (one more than the highest: the lock makes that safe for many writers)."""
    from ares import __version__
    from ares.batch.lot_report import figure_verdict, rows

    data, _ = rows(judged, name)
    created = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    items = [{"idx": i, **{c: _num(row[c]) if c in NUMERIC_ITEM_COLUMNS else str(row[c] or "") for c in ITEM_COLUMNS},
              **{c: (None if r.get(c) is None else int(r[c])) for c in BIN_COLUMNS}}
             for i, (row, r) in enumerate(zip(data, judged.results))]
    figs, checks = [], []
    for i, r in enumerate(judged.results):
        for q, f in (r.get("figures") or {}).items():
            figs.append({"idx": i, "quantity": q, "value": _num(f.get("value")), "se": _num(f.get("se")),
                         "unit": f.get("unit") or "", "verdict": figure_verdict(f)})
        for k in judged.yields:
            checks.append({"idx": i, "limit_text": k, "outcome": data[i].get(k) or ""})
    screen_cols = [c.name for c in t.screens.c if c.name != "lot_id"]
    screens = [{c: s.get(c) for c in screen_cols} for s in judged.screens]
    if db.conn.in_transaction():
        db.conn.commit()  # (a read before: its transaction ends, the append takes the lock)
    with write_lock(db.conn) as c:
        lot_id = int(c.execute(sa.select(sa.func.coalesce(sa.func.max(t.lots.c.lot_id), 0))).scalar()) + 1
        c.execute(t.lots.insert().values(lot_id=lot_id, name=name, created=created, ares_version=__version__,
                                         n_items=len(data), limits_set=int(bool(judged.limits))))
        bins = [{"soft_bin": sb, "hard_bin": b["hard"], "name": b["name"], "count": b["count"],
                 "hard_name": b.get("hard_name"), "pass": None if b.get("pass") is None else int(bool(b["pass"]))}
                for sb, b in judged.bins.items()]
        for table, rowset in ((t.items, items), (t.figures, figs), (t.checks, checks), (t.screens, screens),
                              (t.bins, bins)):
            if rowset:
                c.execute(table.insert(), [{"lot_id": lot_id, **r} for r in rowset])
    return lot_id


def lots(db: Db) -> list[dict]:
    """Every lot with its item counts and overall yield (passed / items, errored included)."""
    counts: dict[int, dict[str, int]] = {}
    for lot_id, verdict, n in _rows(db, sa.select(t.items.c.lot_id, t.items.c.verdict, sa.func.count())
                                    .group_by(t.items.c.lot_id, t.items.c.verdict)):
        counts.setdefault(lot_id, {})[verdict] = n
    out = []
    for lot_id, name, created, ver, n, limited in _rows(db, sa.select(
            t.lots.c.lot_id, t.lots.c.name, t.lots.c.created, t.lots.c.ares_version, t.lots.c.n_items,
            t.lots.c.limits_set).order_by(t.lots.c.lot_id)):
        c = counts.get(lot_id, {})
        out.append({"lot_id": lot_id, "name": name, "created": created, "ares_version": ver, "items": n,
                    "passed": c.get("pass", 0), "failed": c.get("FAIL", 0), "errors": c.get("error", 0),
                    "limits_set": bool(limited)})
    return out


def find_lot(db: Db, ref: str) -> int:
    """A lot by id or name (the newest of that name)."""
    from ares.errors import InputError

    rows = _rows(db, sa.select(t.lots.c.lot_id).where(t.lots.c.name == ref).order_by(t.lots.c.lot_id.desc()))
    if not rows and str(ref).isdigit():
        rows = _rows(db, sa.select(t.lots.c.lot_id).where(t.lots.c.lot_id == int(ref)))
    if not rows:
        raise InputError(f"results database {db.name}: no lot '{ref}' (ares lots list shows them)")
    return int(rows[0][0])


def quantities(db: Db, lot_id: int) -> list[str]:
    """The canonical names of the quantities measured in a lot, sorted."""
    return [r[0] for r in _rows(db, sa.select(t.figures.c.quantity).distinct()
                                .where(t.figures.c.lot_id == lot_id).order_by(t.figures.c.quantity))]


def numeric_columns(db: Db, lot_id: int) -> set[str]:
    """The columns of ``item_rows`` that hold numbers (wafer x/y, bins, each quantity and its
    SE); the others are text."""
    return set(NUMERIC_ITEM_COLUMNS) | set(BIN_COLUMNS) | {c for q in quantities(db, lot_id) for c in (q, f"{q}_se")}


def item_rows(db: Db, lot_id: int) -> tuple[list[str], list[tuple]]:
    """The lot's items, one row each: the traceability columns, the bins, then value and SE
    of every quantity (sorted by name), then every limit's and screen's outcome."""
    cols_sql = [t.items.c[c] for c in ("idx", *ITEM_COLUMNS, *BIN_COLUMNS)]
    items = _rows(db, sa.select(*cols_sql).where(t.items.c.lot_id == lot_id).order_by(t.items.c.idx))
    qs = quantities(db, lot_id)
    ls = [r[0] for r in _rows(db, sa.select(t.checks.c.limit_text).distinct()
                              .where(t.checks.c.lot_id == lot_id).order_by(t.checks.c.limit_text))]
    figs = {(i, q): (v, s) for i, q, v, s in _rows(db, sa.select(
        t.figures.c.idx, t.figures.c.quantity, t.figures.c.value, t.figures.c.se).where(t.figures.c.lot_id == lot_id))}
    chk = {(i, k): o for i, k, o in _rows(db, sa.select(t.checks.c.idx, t.checks.c.limit_text, t.checks.c.outcome)
                                          .where(t.checks.c.lot_id == lot_id))}
    cols = list(ITEM_COLUMNS) + list(BIN_COLUMNS) + [c for q in qs for c in (q, f"{q}_se")] + ls
    out = []
    for idx, *rest in items:
        row = list(rest)
        for q in qs:
            row += list(figs.get((idx, q), (None, None)))
        row += [chk.get((idx, k), "") for k in ls]
        out.append(tuple(row))
    return cols, out


def screens(db: Db, lot_id: int) -> list[dict]:
    """The lot's screens (static limits and dynamic PAT limits) as stored."""
    cols = [c.name for c in t.screens.c if c.name != "lot_id"]
    return [dict(zip(cols, r)) for r in _rows(db, sa.select(*[t.screens.c[c] for c in cols])
                                              .where(t.screens.c.lot_id == lot_id).order_by(t.screens.c.screen))]


def bins(db: Db, lot_id: int) -> dict[int, dict]:
    """The lot's bins: {soft bin: {hard, hard_name, pass, name, count}} (a lot of schema 2:
    the default bins' hard names and pass/fail)."""
    from ares.batch.screens import DEFAULT_HARD

    out = {}
    for sb, hb, nm, n, hn, ok in _rows(db, sa.select(
            t.bins.c.soft_bin, t.bins.c.hard_bin, t.bins.c.name, t.bins.c["count"], t.bins.c.hard_name,
            t.bins.c["pass"]).where(t.bins.c.lot_id == lot_id).order_by(t.bins.c.soft_bin)):
        default = DEFAULT_HARD.get(hb, (f"hard bin {hb}", False))
        out[sb] = {"hard": hb, "name": nm, "count": n, "hard_name": default[0] if hn is None else hn,
                   "pass": default[1] if ok is None else bool(ok)}
    return out


def figures(db: Db, lot_id: int) -> dict[int, dict[str, dict]]:
    """{item index: {quantity: {value, se, unit, verdict}}} of a lot (a declared figure's
    verdict "exact: why" gives its "exact": why back, as its JSON form has it)."""
    from ares.analysis.stats.estimate import exact_why

    out: dict[int, dict[str, dict]] = {}
    for i, q, v, s, u, vd in _rows(db, sa.select(t.figures.c.idx, t.figures.c.quantity, t.figures.c.value,
                                                 t.figures.c.se, t.figures.c.unit, t.figures.c.verdict)
                                   .where(t.figures.c.lot_id == lot_id)):
        out.setdefault(i, {})[q] = {"value": v, "se": s, "unit": u, "verdict": vd,
                                    **({"exact": exact_why(vd)} if exact_why(vd) else {})}
    return out


def lot_info(db: Db, lot_id: int) -> dict:
    """The lot's row: name, created, ARES version, items, limits set."""
    r = _rows(db, sa.select(t.lots.c.name, t.lots.c.created, t.lots.c.ares_version, t.lots.c.n_items,
                            t.lots.c.limits_set).where(t.lots.c.lot_id == lot_id))[0]
    return dict(zip(("name", "created", "ares_version", "items", "limits_set"), r), lot_id=lot_id)


def unit_of(db: Db, quantity: str) -> str:
    """The unit a quantity is stored in ("" when no lot has it)."""
    r = _rows(db, sa.select(t.figures.c.unit).where(t.figures.c.quantity == quantity, t.figures.c.unit != "").limit(1))
    return r[0][0] if r else ""


def _measured():
    """A figure with a value that is not only a limit (a limit is not a value of a median)."""
    v = t.figures.c.verdict
    return sa.and_(t.figures.c.value.is_not(None), sa.or_(v.is_(None), v.not_in(("upper limit", "lower limit"))))


def values(db: Db, lot_id: int, quantity: str) -> list[float]:
    """Every item's measured value of ``quantity`` in a lot (items without it, or with only a
    limit of it, left out)."""
    return [float(v) for (v,) in _rows(db, sa.select(t.figures.c.value).where(
        t.figures.c.lot_id == lot_id, t.figures.c.quantity == quantity, _measured()))]


def quantity_stats(db: Db, lot_id: int) -> dict[str, tuple[int, float | None, float | None]]:
    """Quantity -> (items measured, median, IQR) in a lot (computed here: portable SQL; limits left out)."""
    import numpy as np

    vals: dict[str, list[float]] = {}
    for q, v in _rows(db, sa.select(t.figures.c.quantity, t.figures.c.value)
                      .where(t.figures.c.lot_id == lot_id, _measured())):
        vals.setdefault(q, []).append(float(v))
    out = {}
    for q, vs in sorted(vals.items()):
        p25, p50, p75 = np.percentile(np.asarray(vs), [25, 50, 75])
        out[q] = (len(vs), float(p50), float(p75 - p25))
    return out
