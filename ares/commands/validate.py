"""``ares validate FILE...``: check system and scan XML files without touching hardware."""

from __future__ import annotations

import sys

from ares.errors import InputError

NAME = "validate"
HELP = "check scan and system XML files (schema + semantics); exit 0 if all are valid, 2 otherwise"


def add_arguments(parser) -> None:
    parser.add_argument("files", nargs="+", metavar="FILE", help="scan or system XML file")
    parser.add_argument("--quiet", "-q", action="store_true", help="print errors only")


def validate_one(path) -> tuple[str, str]:
    """Schema + semantic checks of one file (and, for a scan, its system), the simulator's
    parameter checks and, for a scan, everything ``ares run`` checks before it starts
    (``ares.scan.preflight``); returns ("scan" | "system", a note), raises ``InputError``."""
    from ares.sim.from_system import sim_params
    from ares.protocol import load_scan, load_system, validate_file

    kind = validate_file(path)
    if kind == "scan":
        from ares.scan.preflight import check_run

        plan = check_run(load_scan(path), refuse_disk=False)
        if not plan.disk_fits():  # (where `ares run` would put it without --out: runs/)
            print(f"{path}: WARNING: {plan.disk_note()}", file=sys.stderr)
        return kind, f"{plan.memory_note()}; {plan.disk_note()}"
    system = load_system(path)
    if system.simulator is not None:
        sim_params(system)
    if system.replay is not None:  # a run on it would refuse missing or mismatched data
        from ares.hardware.replay import replay_descriptor

        replay_descriptor(system)
    return kind, ""


def run(args) -> int:
    bad = 0
    for path in args.files:
        try:
            kind, note = validate_one(path)
        except InputError as exc:
            bad += 1
            print(str(exc), file=sys.stderr)
        else:
            if not args.quiet:
                print(f"{path}: valid {kind} file" + (f" ({note})" if note else ""))
    return 2 if bad else 0
