"""``ares lots list|compare|export``: the lots in a results database (written by ``ares batch``).

``list``: every lot with its items, passed, failed and errored (yield = passed / items);
``compare LOT_A LOT_B``: per quantity, items measured, median and interquartile range in each;
``export LOT [--csv FILE] [--parquet FILE]``: every item of a lot, its traceability, figures, SEs
and limit outcomes -- the same rows and columns in CSV and in Parquet (numbers as float64, an
absent figure as null; text as UTF-8 strings).
"""

from __future__ import annotations

import csv
import sys

NAME = "lots"
HELP = "list, compare and export the lots of a results database"


def add_arguments(p) -> None:
    p.add_argument("action", choices=("list", "compare", "export"))
    p.add_argument("lots", nargs="*", metavar="LOT", help="lot name or id (compare: two; export: one)")
    p.add_argument("--db", metavar="PATH|URL", default="lot/results.sqlite",
                   help="SQLite file or postgresql:// URL (default lot/results.sqlite, as ares batch)")
    p.add_argument("--csv", metavar="FILE", help="export: the CSV file (default: standard output, unless --parquet)")
    p.add_argument("--parquet", metavar="FILE", help="export: a Parquet file of the same rows (typed columns)")


def _list(db) -> None:
    from ares.batch import db as rdb

    rows = rdb.lots(db)
    if not rows:
        print(f"{db.target}: no lots yet")
    for r in rows:
        y = (f"yield {r['passed']}/{r['items']} ({100 * r['passed'] / r['items']:.1f} %)" if r["limits_set"]
             and r["items"] else "no limits set")
        print(f"{r['lot_id']:>4}  {r['name']:<24} {r['created']}  ares {r['ares_version']}  {r['items']} item(s), "
              f"{r['failed']} failed, {r['errors']} errored; {y}")


def _compare(db, a: str, b: str) -> None:
    from ares.batch import db as rdb

    ia, ib = rdb.find_lot(db, a), rdb.find_lot(db, b)
    sa, sb = rdb.quantity_stats(db, ia), rdb.quantity_stats(db, ib)
    print(f"{'quantity':<28} {'n(' + a + ')':>10} {'median':>12} {'IQR':>10}   {'n(' + b + ')':>10} {'median':>12} "
          f"{'IQR':>10}")
    for q in sorted(set(sa) | set(sb)):
        cells = []
        for s in (sa, sb):
            n, med, iqr = s.get(q, (0, None, None))
            cells.append(f"{n:>10} {'-' if med is None else f'{med:.6g}':>12} {'-' if iqr is None else f'{iqr:.4g}':>10}")
        print(f"{q:<28} {cells[0]}   {cells[1]}")


def _export(db, ref: str, path: str | None, parquet: str | None = None) -> None:
    from ares.batch import db as rdb

    lot_id = rdb.find_lot(db, ref)
    cols, rows = rdb.item_rows(db, lot_id)
    if parquet:
        write_parquet(parquet, cols, rows, rdb.numeric_columns(db, lot_id))
        print(f"lot {ref}: {len(rows)} item(s) -> {parquet}", file=sys.stderr)
        if not path:
            return
    fh = open(path, "w", newline="", encoding="utf-8") if path else sys.stdout
    try:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(cols)
        for r in rows:
            w.writerow(["" if v is None else (repr(v) if isinstance(v, float) else v) for v in r])
    finally:
        if path:
            fh.close()
    if path:
        print(f"lot {ref}: {len(rows)} item(s) -> {path}", file=sys.stderr)


def write_parquet(path: str, cols: list[str], rows: list[tuple], numeric: set[str]) -> None:
    """The rows as a Parquet file (written as .tmp and renamed): ``numeric`` columns float64,
    the others strings; None is null."""
    import os

    import pyarrow as pa
    import pyarrow.parquet as pq

    fields = [pa.field(c, pa.float64() if c in numeric else pa.string()) for c in cols]
    data = {c: [r[i] for r in rows] for i, c in enumerate(cols)}
    data = {c: [None if v is None else (float(v) if c in numeric else str(v)) for v in vs] for c, vs in data.items()}
    table = pa.table(data, schema=pa.schema(fields))
    tmp = f"{path}.tmp"
    pq.write_table(table, tmp)
    os.replace(tmp, path)


def run(args) -> int:
    from pathlib import Path

    from ares.batch import db as rdb
    from ares.errors import InputError

    want = {"list": 0, "compare": 2, "export": 1}[args.action]
    if len(args.lots) != want:
        raise InputError(f"ares lots {args.action}: give {want} lot(s) (name or id), not {len(args.lots)}")
    from ares.safefile import output_file, writing

    for opt, path in (("--csv", getattr(args, "csv", None)), ("--parquet", getattr(args, "parquet", None))):
        if path and args.action == "export":  # before the work (ares.safefile)
            output_file(path, opt)
    if not args.db.startswith(("postgresql://", "postgres://")) and not Path(args.db).is_file():
        raise InputError(f"{args.db}: no results database (ares batch writes one; --db names it)")
    with rdb.connect(args.db) as db:
        if args.action == "list":
            _list(db)
        elif args.action == "compare":
            _compare(db, *args.lots)
        else:
            with writing(args.csv or args.parquet):
                _export(db, args.lots[0], args.csv, args.parquet)
    return 0
