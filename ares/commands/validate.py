"""``ares validate FILE...``: check system and scan XML files without touching hardware."""

from __future__ import annotations

import sys

from ares.errors import InputError

NAME = "validate"
HELP = "check scan and system XML files (schema + semantics); exit 0 if all are valid, 2 otherwise"


def add_arguments(parser) -> None:
    parser.add_argument("files", nargs="+", metavar="FILE", help="scan or system XML file")
    parser.add_argument("--quiet", "-q", action="store_true", help="print errors only")


def run(args) -> int:
    from ares.protocol import validate_file

    bad = 0
    for path in args.files:
        try:
            kind = validate_file(path)
        except InputError as exc:
            bad += 1
            print(str(exc), file=sys.stderr)
        else:
            if not args.quiet:
                print(f"{path}: valid {kind} file")
    return 2 if bad else 0
