"""``ares batch ITEMS... [--lot LOT.xml]``: analyse many run directories and recorded data
sets in parallel on Dask and write one lot table (CSV, HDF5, PDF).

Items: run directories, EMVA 1288 descriptor files, frame stacks (image folder, ``.npy``,
``.npz``, ``file.h5:/dataset``), given on the command line and/or as ``<item>`` elements of
the lot file (which also declares the limits). ``--stack SPEC --split N`` accumulates one
huge stack on N workers instead (exact: the same decomposition as one process).

Exit: 0 every item analysed and within the limits; 4 some item failed a limit; 1 some item
could not be analysed (the others are in the table); 2 bad input; 3 the cluster is not
reachable.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

NAME = "batch"
HELP = "analyse many runs / data sets in parallel on Dask and write the lot report"


def add_arguments(p) -> None:
    p.add_argument("items", nargs="*", help="run directories, EMVA descriptors, frame stacks")
    p.add_argument("--lot", metavar="LOT.xml", help="lot file: items (with sensor names, wafer x/y) and limits")
    p.add_argument("--out", metavar="DIR", default="lot", help="where the lot report and the cache go (default ./lot)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler (tcp://host:8786); default: "
                                                          "a local cluster, one worker process per core")
    p.add_argument("--workers", type=int, metavar="N", help="workers of the local cluster (default: the cores)")
    p.add_argument("--no-cache", action="store_true", help="recompute every item (the cache is still refreshed)")
    p.add_argument("--rerun", action="store_true", help="repeat every run directory from its directory alone "
                                                        "(as ares rerun) on the workers, into OUT/reruns, and "
                                                        "report the new runs")
    p.add_argument("--stack", metavar="SPEC", help="one huge stack (.npy or file.h5:/dataset) split over workers")
    p.add_argument("--split", type=int, default=0, metavar="N", help="frame chunks for --stack (default: workers)")
    p.add_argument("--verify", action="store_true", help="cache keys from the full content hash of every file "
                                                         "(default: size, time and the first/last blocks)")
    p.add_argument("--db", metavar="PATH|URL", help="results database the lot is appended to: a SQLite file or "
                                                    "any SQLAlchemy URL (sqlite:///path, postgresql+psycopg://"
                                                    "user@host/db); default OUT/results.sqlite")
    p.add_argument("--no-db", action="store_true", help="do not append the lot to a results database")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress line")


def _stack(args, client) -> int:
    from ares.analysis.noise.anova import decompose_dark
    from ares.batch.cluster import split_accumulate
    from ares.labels import COMPONENTS

    from ares.batch.items import one_line
    from ares.errors import InputError

    n = args.split or len(client.scheduler_info()["workers"]) or 1
    try:
        acc = split_accumulate(client, _absolute(args.stack), n)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 -- a worker's failure is one sentence, never a traceback
        raise InputError(one_line(args.stack, exc)) from None
    comps = decompose_dark(acc)
    if args.json:
        print(json.dumps({k: e.to_dict() for k, e in comps.items()}, indent=2))
    else:
        print(f"{args.stack}: {acc.n_frames} frames of {acc.shape[0]} x {acc.shape[1]}, in {n} chunks")
        for k, e in comps.items():
            print(f"  {k:<14} {e.text():<28} {COMPONENTS.get(k, '')}")
    return 0


def _absolute(spec: str) -> str:
    """The item spec with its file made absolute on the client (``file.h5:/dataset`` keeps
    its dataset): workers on a scheduler resolve nothing in their own working directory."""
    from ares.hardware.stackfiles import split_spec

    p, inner = split_spec(spec)
    return str(p.resolve()) + (f":{inner}" if inner else "")


def run(args) -> int:
    from ares.batch import lot_pdf, lot_report
    from ares.batch.cluster import close_client, make_client, progress_line, run_items
    from ares.errors import InputError
    from ares.protocol.lot import load_lot

    lot = load_lot(args.lot) if args.lot else None
    paths = [_absolute(p) for p in args.items] + [_absolute(str(it.path)) for it in (lot.items if lot else ())]
    if not paths and not args.stack:
        raise InputError("no items (give run directories / data sets, or a lot file with <item>s)")
    from ares.hardware.stackfiles import split_spec

    for p in paths:
        if not split_spec(p)[0].exists():
            raise InputError(f"{p}: no such file or directory")
    from ares.safefile import output_folder, writing

    if not args.stack:  # before the work (ares.safefile): the checks ares run makes for --out
        output_folder(args.out, "--out")
    if not args.no_db and not args.stack:  # an unusable database is said before the work, not after
        from ares.batch import db

        with db.connect(args.db or str(Path(args.out) / "results.sqlite")):
            pass
    client = make_client(args.scheduler, args.workers)
    try:
        if args.stack:
            return _stack(args, client)
        out = Path(args.out)
        cache = out / "cache"
        cache.mkdir(parents=True, exist_ok=True)
        if args.no_cache:
            for p in cache.glob("*.json"):
                p.unlink()
        with open(out / "lot.log", "a", encoding="utf-8") as log:
            log.write(f"# ares batch: {len(paths)} item(s), scheduler {args.scheduler or 'local'}\n")
            show = progress_line(log=log, quiet=args.quiet)
            partial = out / "lot.partial.csv"

            def progress(done, total, r):
                show(done, total, r)
                with open(partial, "a", encoding="utf-8") as fh:  # the partial table, as items finish
                    fh.write(f"{done},{r['item']},{r.get('status')},{r.get('error', '')}\n")

            partial.write_text("done,item,status,error\n")
            results = run_items(client, paths, str(cache.resolve()), progress,
                                rerun_into=str((out / "reruns").resolve()) if args.rerun else None,
                                verify=args.verify)
    finally:
        close_client(client)
    meta = {_absolute(str(it.path)): {"sensor": it.sensor, "x": it.x, "y": it.y, "wafer": it.wafer}
            for it in (lot.items if lot else ())}
    judged = lot_report.judge(results, lot.limits if lot else (), meta)
    from ares.batch.screens import screen

    screen(judged, lot.screens if lot else (), lot.limit_bins if lot else (),  # dynamic limits, then bins
           lot.hard_bins if lot else (), lot.soft_bins if lot else ())
    name = lot.name if lot else out.resolve().name
    from ares.rundir.files import write_atomic

    from ares.batch import stdf

    with writing(out):
        write_atomic(out / "lot.csv", lot_report.to_csv(judged, name).encode())
        write_atomic(out / "lot_columns.csv", lot_report.columns_csv(judged, name).encode())  # label + unit per column
        lot_report.write_h5(judged, out / "lot.h5", name)
        lot_pdf.write_pdf(judged, out / "lot.pdf", name)
        stdf.write(stdf.from_judged(judged, name), out / "lot.stdf")  # for yield tools
    (out / "lot.partial.csv").unlink(missing_ok=True)
    if not args.no_db:
        from ares.batch import db

        from ares.batch.dbconn import ResultsDbError

        try:
            with db.connect(args.db or str(out / "results.sqlite")) as conn:
                db.append_lot(conn, name, judged)
        except ResultsDbError as exc:
            raise ResultsDbError(f"{exc}; the lot is not in it, its files are ({out}/lot.csv, lot.h5, lot.pdf, lot.stdf): "
                                 f"run ares batch again to append it (its items come from the cache)") from None
    if args.json:
        print(json.dumps({"lot": name, "yield": judged.yields, "items": results}, indent=2))
    else:
        n_err = sum(r.get("status") == "error" for r in results)
        n_cached = sum(bool(r.get("cached")) for r in results)
        print(f"lot {name}: {len(results)} item(s), {n_cached} from the cache, {n_err} failed; "
              f"report in {out}/lot.csv (columns: lot_columns.csv), lot.h5, lot.pdf, lot.stdf")
        for k, (a, b) in judged.yields.items():
            print(f"  yield {k}: {a}/{b} ({b} item(s) of the lot, errored ones count as failed)")
        for sb, b in judged.bins.items():
            print(f"  bin {b['hard']}/{sb} {b['name']}: {b['count']}/{len(results)}")
        if not judged.limits and not judged.bins:
            print(f"  {lot_report.NO_LIMITS}: no item is judged pass or fail")
        for r in results:
            if r.get("rerun_of"):
                differ = f" (differ: {'; '.join(r['differ'])})" if r.get("differ") else ""
                print(f"  rerun of {r['rerun_of']}: {r['reproduced']} stage result(s) and their arrays reproduced"
                      f"{differ} -> {r['item']}")
            if r.get("status") == "error":
                print(f"  FAILED {r['error']}", file=sys.stderr)
    if any(r.get("status") == "error" for r in results):
        return 1
    return 4 if any(r.get("passed") is False for r in results) else 0
