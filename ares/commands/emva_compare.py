"""``ares emva-compare A.xml B.xml``: the certification compare of two EMVA 1288 results files.

Every name of either file is listed as PASS (equal to ``--digits`` significant digits, 7 by
default: the reference implementation's criterion; arrays element by element), FAIL or
MISSING (in one file only), with both values. Exit 0 only when every name passes, 1
otherwise. Runs on current NumPy (``ares.report.emva_xml``); the files are ``ares emva
--xml`` output or the reference implementation's (docs/emva_xml.md).
"""

from __future__ import annotations

import argparse
import json

NAME = "emva-compare"
HELP = "compare two EMVA 1288 results XML files name by name (certification check)"


def _digits(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--digits must be a whole number, not {text!r}") from None
    if not 1 <= n <= 17:
        raise argparse.ArgumentTypeError(f"--digits must be 1 - 17 (a float carries 17), not {n}")
    return n


def add_arguments(parser) -> None:
    parser.add_argument("a", metavar="A.xml", help="first results file (e.g. the reference implementation's)")
    parser.add_argument("b", metavar="B.xml", help="second results file (e.g. ares emva --xml)")
    parser.add_argument("--digits", type=_digits, default=7, help="significant digits that must agree (default 7)")
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    parser.add_argument("--failures", action="store_true", help="list only the names that do not pass")


def run(args) -> int:
    from ares.report.emva_xml import PASS, compare, format_rows, read_xml

    a, b = read_xml(args.a), read_xml(args.b)
    rows = compare(a, b, args.digits)
    shown = [r for r in rows if r.status != PASS] if args.failures else rows
    if args.json:
        print(json.dumps({"a": args.a, "b": args.b, "digits": args.digits, "all_pass": all(r.status == PASS for r in rows),
                          "rows": [r.__dict__ for r in shown]}, indent=2))
    else:
        print(format_rows(shown, args.a, args.b))
        if args.failures:
            print(f"({len(rows) - len(shown)} passing names not shown)")
    return 0 if rows and all(r.status == PASS for r in rows) else 1
