"""``ares lots list|compare|export|certificate|trend``: the lots in a results database (written
by ``ares batch``).

``list``: every lot with its items, passed, failed and errored (yield = passed / items);
``compare LOT_A LOT_B``: per quantity, items measured, median and interquartile range in each;
``export LOT [--csv FILE] [--parquet FILE] [--stdf FILE]``: every item of a lot, its traceability,
bins, figures, SEs and limit and screen outcomes -- the same rows and columns in CSV and in
Parquet (numbers as float64, an absent figure as null; text as UTF-8 strings); STDF V4 for
yield tools (``ares.batch.stdf``);
``certificate LOT [ITEM]``: a certificate of performance per sensor, one PDF page each
(``ares.batch.certificate``); ``trend QUANTITY``: median and spread per lot over the database's
lots with control limits, a plot and a CSV (``ares.batch.trend``).
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

NAME = "lots"
HELP = "list, compare and export the lots of a results database"


def add_arguments(p) -> None:
    p.add_argument("action", choices=("list", "compare", "export", "certificate", "trend"))
    p.add_argument("lots", nargs="*", metavar="LOT", help="lot name or id (compare: two; export: one; certificate: "
                                                          "one, then optionally an ITEM: serial, path or #N; "
                                                          "trend: the QUANTITY instead)")
    p.add_argument("--db", metavar="PATH|URL", default="lot/results.sqlite",
                   help="a SQLite file, or any SQLAlchemy URL: sqlite:///path, postgresql+psycopg://user@host/db "
                        "(default lot/results.sqlite, as ares batch)")
    p.add_argument("--csv", metavar="FILE", help="export: the CSV file (default: standard output, unless --parquet)")
    p.add_argument("--parquet", metavar="FILE", help="export: a Parquet file of the same rows (typed columns)")
    p.add_argument("--out", metavar="FILE", help="certificate: the PDF (default certificates_LOT[_ITEM].pdf); trend: "
                                                 "the plot, .pdf or .png (default trend_QUANTITY.pdf; the CSV beside "
                                                 "it, or --csv)")
    p.add_argument("--stdf", metavar="FILE", help="export: the lot as STDF V4 (a PTR per measurement with its "
                                                  "limits, a PRR per sensor with bins and wafer x/y, WRR, HBR/SBR)")


def _list(db) -> None:
    from ares.batch import db as rdb

    rows = rdb.lots(db)
    if not rows:
        print(f"{db.name}: no lots yet")
    for r in rows:
        y = (f"yield {r['passed']}/{r['items']} ({100 * r['passed'] / r['items']:.1f} %)" if r["limits_set"]
             and r["items"] else "no limits set")
        print(f"{r['lot_id']:>4}  {r['name']:<24} {r['created']}  ares {r['ares_version']}  {r['items']} item(s), "
              f"{r['failed']} failed, {r['errors']} errored; {y}")


def _compare(db, a: str, b: str) -> None:
    from ares.batch import db as rdb

    ia, ib = rdb.find_lot(db, a), rdb.find_lot(db, b)
    sa, sb = rdb.quantity_stats(db, ia), rdb.quantity_stats(db, ib)
    from ares.batch.vocabulary import quantity_heading

    qs = sorted(set(sa) | set(sb))
    heads = {q: quantity_heading(q, rdb.unit_of(db, q)) for q in qs}  # the label the scan surfaces give it, its unit
    w = max([28] + [len(h) + 1 for h in heads.values()])
    print(f"{'quantity [unit]':<{w}} {'n(' + a + ')':>10} {'median':>12} {'IQR':>10}   {'n(' + b + ')':>10} "
          f"{'median':>12} {'IQR':>10}   key")
    for q in qs:
        cells = []
        for s in (sa, sb):
            n, med, iqr = s.get(q, (0, None, None))
            cells.append(f"{n:>10} {'-' if med is None else f'{med:.6g}':>12} {'-' if iqr is None else f'{iqr:.4g}':>10}")
        print(f"{heads[q]:<{w}} {cells[0]}   {cells[1]}   {q}")


def _export(db, ref: str, path: str | None, parquet: str | None = None, stdf_path: str | None = None) -> None:
    from ares.batch import db as rdb

    lot_id = rdb.find_lot(db, ref)
    if stdf_path:
        from ares.batch import stdf

        n = stdf.write(stdf.from_db(db, lot_id), _writable(stdf_path, "--stdf"))
        print(f"lot {ref}: STDF V4, {n} records -> {stdf_path}", file=sys.stderr)
        if not path and not parquet:
            return
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


def _writable(path, option: str) -> Path:
    """The output ``path`` of ``option`` checked before the work: its folder exists, and it is
    not a folder itself (the storage errors of writing it: ``rundir.files.storage``)."""
    from ares.errors import InputError

    p = Path(path)
    if p.is_dir():
        raise InputError(f"{option} {p}: is a folder; give a file name")
    if not p.parent.is_dir():
        raise InputError(f"{option} {p}: the folder {p.parent} does not exist")
    return p


def _certificate(db, ref: str, item: str | None, out: str | None) -> None:
    from ares.batch import certificate
    from ares.batch import db as rdb

    lot_id = rdb.find_lot(db, ref)
    cols, rows = rdb.item_rows(db, lot_id)
    which = certificate.select(cols, rows, item)
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in f"{ref}" + (f"_{item}" if item else ""))
    path = _writable(out or f"certificates_{safe}.pdf", "--out")
    n = certificate.write(db, lot_id, which, path)
    print(f"lot {ref}: {len(which)} certificate(s), {n} page(s) -> {path}")


def _trend(db, quantity: str, out: str | None, csv_path: str | None) -> None:
    from ares.batch import db as rdb
    from ares.batch import trend
    from ares.batch.vocabulary import canonical, quantity_label
    from ares.errors import InputError
    from ares.rundir.files import storage, write_atomic

    q = canonical(quantity)
    rows, limits = trend.trend(db, q)
    if not rows:
        raise InputError(f"results database {db.name}: no lot measured '{quantity}' (ares lots compare lists the "
                         f"quantities of two lots)")
    plot = _writable(out or f"trend_{q}.pdf", "--out")
    table = _writable(csv_path, "--csv") if csv_path else plot.with_suffix(".csv")
    with storage(table):
        write_atomic(table, trend.to_csv(rows).encode())
    with storage(plot):
        trend.plot(rows, limits, q, rdb.unit_of(db, q), plot)
    flagged = [r["lot"] for r in rows if r["out_of_control"] == "yes"]
    lim = limits["note"] or (f"control limits {limits['low']:.5g} .. {limits['high']:.5g} (centre "
                             f"{limits['centre']:.5g}); outside: {', '.join(flagged) or 'none'}")
    print(f"{quantity_label(q)} ({q}) over {len(rows)} lot(s): {lim}; plot {plot}, table {table}")


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
    from ares.batch.dbconn import sqlite_file
    from ares.errors import InputError

    want = {"list": (0,), "compare": (2,), "export": (1,), "certificate": (1, 2), "trend": (1,)}[args.action]
    if len(args.lots) not in want:
        what = "a QUANTITY" if args.action == "trend" else ("a lot and optionally an ITEM"
                                                            if args.action == "certificate" else f"{want[0]} lot(s)")
        raise InputError(f"{args.action}: give {what} (name or id), not {len(args.lots)} argument(s)")
    from ares.safefile import output_file, writing

    for opt, path in (("--csv", getattr(args, "csv", None)), ("--parquet", getattr(args, "parquet", None)),
                      ("--stdf", getattr(args, "stdf", None))):
        if path and args.action == "export":  # before the work (ares.safefile)
            output_file(path, opt)
    f = sqlite_file(args.db)
    if f is not None and not Path(f).is_file():
        raise InputError(f"{args.db}: no results database (ares batch writes one; --db names it)")
    with rdb.connect(args.db) as db:
        if args.action == "list":
            _list(db)
        elif args.action == "compare":
            _compare(db, *args.lots)
        elif args.action == "certificate":
            _certificate(db, args.lots[0], args.lots[1] if len(args.lots) > 1 else None, args.out)
        elif args.action == "trend":
            _trend(db, args.lots[0], args.out, args.csv)
        else:
            with writing(args.csv or args.parquet or args.stdf):
                _export(db, args.lots[0], args.csv, args.parquet, args.stdf)
    return 0
