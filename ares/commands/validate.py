"""``ares validate FILE...``: check system and scan XML files without touching hardware."""

from __future__ import annotations

import sys

from ares.errors import InputError

NAME = "validate"
HELP = "check scan and system XML files (schema + semantics); exit 0 if all are valid, 2 otherwise"


def add_arguments(parser) -> None:
    parser.add_argument("files", nargs="+", metavar="FILE", help="scan or system XML file")
    parser.add_argument("--quiet", "-q", action="store_true", help="print errors only")


def validate_one(path) -> str:
    """Schema + semantic checks of one file (and, for a scan, its system), plus the
    simulator's own parameter checks; returns "scan" or "system", raises ``InputError``."""
    from ares.hardware.factory import sim_params
    from ares.protocol import load_scan, load_system, validate_file

    kind = validate_file(path)
    system = load_scan(path).system if kind == "scan" else load_system(path)
    if system.simulator is not None:
        sim_params(system)
    return kind


def run(args) -> int:
    bad = 0
    for path in args.files:
        try:
            kind = validate_one(path)
        except InputError as exc:
            bad += 1
            print(str(exc), file=sys.stderr)
        else:
            if not args.quiet:
                print(f"{path}: valid {kind} file")
    return 2 if bad else 0
