"""``ares report RUN_DIR``: CSV tables and a PDF report from a run directory alone.

Writes ``ptc.csv``, ``components.csv``, ``key_figures.csv``, ``report.h5`` and
``report.pdf`` into the run directory (``--csv DIR`` / ``--hdf5 FILE`` / ``--pdf FILE``
elsewhere; given any of them, only those are written). ``--json`` prints the key figures and the files as JSON. A
partial run is reported as far as it goes (exit 0, with a note); a missing or
unreadable run directory is one sentence, exit 2. ``--gain K`` (with its unit, as
``ares analyze`` takes it): a run that measured no gain (the temperature scan) gets its
dark currents in e-/s beside DN/s; the gain is recorded in run.json (``gain_given``) and the
dark_current/temperature analyses of scan_results.json are computed again with it.
"""

from __future__ import annotations

import json
import sys

NAME = "report"
HELP = "write CSV/HDF5 tables and a PDF report from a run directory alone"


def add_arguments(parser) -> None:
    parser.add_argument("run_dir", metavar="RUN_DIR", help="run directory written by 'ares run'")
    parser.add_argument("--pdf", metavar="FILE", help="write the PDF here (default: RUN_DIR/report.pdf)")
    parser.add_argument("--csv", metavar="DIR", help="write the CSV tables here (default: RUN_DIR)")
    parser.add_argument("--hdf5", metavar="FILE", help="write the HDF5 tables here (default: RUN_DIR/report.h5)")
    parser.add_argument("--json", action="store_true", help="print key figures and written files as JSON")
    from ares.commands.argtypes import gain, positive

    parser.add_argument("--gain", type=gain, default=None, metavar="K",
                        help="system gain for dark currents in e-/s when the run measured none (0.28DN/e-, "
                             "3.57e-/DN, 70uV/e- with --adc-lsb-uv); recorded in run.json")
    parser.add_argument("--adc-lsb-uv", type=positive, default=None, metavar="UV",
                        help="the ADC step in uV, to turn a --gain in uV/e- into DN/e-")


GAIN_ANALYSES = ("dark_current", "temperature", "dark_temperature")  # the analyses a given gain changes


def give_gain(run_dir, k: float, text: str) -> None:
    """Record a gain given by ``--gain`` in run.json and compute the analyses that use it
    again (scan_results.json); a run whose PTC measured K keeps its own (``dark_gain``)."""
    from pathlib import Path

    from ares.results.registry import SCAN_ANALYSES
    from ares.rundir.files import dump_json, storage
    from ares.rundir.record import load_run

    d = Path(run_dir)
    meta = json.loads((d / "run.json").read_text())
    meta["gain_given"] = {"value": k, "se": None, "text": text,
                          "source": "ares report --gain; its own uncertainty is not in the e-/s SEs"}
    with storage(d / "run.json"):
        dump_json(d / "run.json", meta)
    if not (d / "scan_results.json").is_file():
        return
    doc = json.loads((d / "scan_results.json").read_text())
    record = load_run(d)
    for name in GAIN_ANALYSES:
        if name in (doc.get("analyses") or {}):
            doc["analyses"][name] = SCAN_ANALYSES[name](record)
    with storage(d / "scan_results.json"):
        dump_json(d / "scan_results.json", doc)
        from ares.rundir import manifest

        if (d / manifest.MANIFEST).exists():  # rewritten by ARES on purpose: its new hash recorded
            manifest.record(d, [d / "scan_results.json"], by=manifest.RUN)


def run(args) -> int:
    from ares.report import read_run, tables, write_reports

    formats = [f for f, opt in (("csv", args.csv), ("hdf5", args.hdf5), ("pdf", args.pdf)) if opt] \
        or ["csv", "hdf5", "pdf"]
    from ares.rundir.state import REPORTS_INCOMPLETE, owner
    from ares.rundir.record import clean_report_leftovers, set_reports_state

    from ares.safefile import output_file, output_folder, writing

    r = read_run(args.run_dir, verify_arrays=True)  # (incomplete / corrupt: one sentence, exit 2)
    # every output checked before the work (ares.safefile: the checks ares run makes)
    for opt, path in (("--pdf", args.pdf), ("--hdf5", args.hdf5)):
        if path:
            output_file(path, opt)
    if args.csv:
        output_folder(args.csv, "--csv")
    if not (args.pdf and args.hdf5 and args.csv):  # (some go into the run directory)
        output_folder(r.dir, "RUN_DIR")
    if args.gain is not None:
        give_gain(r.dir, args.gain.dn_per_e(args.adc_lsb_uv), args.gain.text)
        r = read_run(args.run_dir)
    repair = r.status == REPORTS_INCOMPLETE and not (args.pdf or args.csv or args.hdf5)
    if repair:  # the reports a signal cut short, written now: the run reads as done again
        clean_report_leftovers(r.dir)
        set_reports_state(r.dir, "writing", **owner())
        r = read_run(args.run_dir)
    from ares.rundir import manifest

    for n in r.notes:  # (files of the run that are missing: named, whether the report rebuilds them or not)
        if manifest.MANIFEST in n:
            print(f"note: {r.dir}: {n}", file=sys.stderr)
    altered = manifest.problems(r.dir, by=manifest.REPORT)  # reports changed since ARES wrote them
    target = args.pdf if formats == ["pdf"] else args.hdf5 if formats == ["hdf5"] else args.csv or r.dir
    with writing(target):
        files = write_reports(args.run_dir, formats, pdf_path=args.pdf, csv_dir=args.csv, h5_path=args.hdf5)
    written = {p.resolve() for p in files}
    for rel, what in altered:  # never rewritten (nor left) without saying so
        fate = "written anew now" if (r.dir / rel).resolve() in written else "left as found"
        print(f"note: {r.dir / rel} was {what.replace('altered', 'altered after ARES wrote it', 1)}: {fate}",
              file=sys.stderr)
    if repair:
        set_reports_state(r.dir, "complete")
    note = r.incompleteness()
    if args.json:
        kf = tables.compute_key_figures(r)
        json.dump({"run_dir": str(r.dir), "status": r.status, "complete": r.complete, "note": note,
                   "files": [str(p) for p in files], "key_figures": kf}, sys.stdout, indent=1, allow_nan=False)
        sys.stdout.write("\n")
    else:
        if note:
            print(note, file=sys.stderr)
        for p in files:
            print(p)
    skipped = [f"{name} ({opt})" for fmt, name, opt in (("csv", "CSV tables", "--csv DIR"),
                                                         ("hdf5", "report.h5", "--hdf5 FILE"),
                                                         ("pdf", "report.pdf", "--pdf FILE")) if fmt not in formats]
    if skipped:  # never silently: say what was left out and how to ask for it
        print(f"not written: {', '.join(skipped)} -- only the files named by an option are written when any is given",
              file=sys.stderr)
    return 0
