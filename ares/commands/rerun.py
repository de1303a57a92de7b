"""``ares rerun RUN_DIR``: repeat a run exactly from what its directory holds
(verbatim scan and system XML, checked against their SHA-256, seed and frame override),
then say how many stage results (and their arrays, by their recorded SHA-256) match the
original's, and whether the original directory is still as written (``ares.rundir.check``: an
incomplete or corrupt original is one sentence on stderr and exit 2, after the rerun)."""

from __future__ import annotations

import sys
from pathlib import Path
from ares.rundir.compare import compare, original_damage

NAME = "rerun"
HELP = "repeat a run from its run directory (same XML, same seed) into a new run directory"


def add_arguments(parser) -> None:
    from ares.commands.run import add_common

    parser.add_argument("run_dir", metavar="RUN_DIR", help="a run directory written by 'ares run'")
    add_common(parser)


def run(args) -> int:
    from ares.commands.run import execute
    from ares.scan import load_run

    rec = load_run(args.run_dir)
    damage = original_damage(rec)  # the rerun still runs: it needs only the verbatim XML
    out = args.out
    if out is None:
        base = Path(args.run_dir).resolve()
        k = 1
        while (out := base.with_name(f"{base.name}_rerun{k}")).exists():
            k += 1
    rc = execute(rec.scan, args, seed=rec.meta.get("seed"), frames=rec.meta.get("frames_override"),
                 argv=["rerun", str(args.run_dir)], out_dir=out)
    try:
        new = load_run(out)
    except Exception:  # the rerun's own outcome was already reported
        new = None
    if new is not None:
        same, n, diff = compare(rec, new)
        if n and not args.json:
            line = f"reproduced: {same} of {n} stage result(s) identical to {args.run_dir} (results and arrays)"
            if diff:
                line += f" (differ: {'; '.join(diff[:5])}{' ...' if len(diff) > 5 else ''})"
            print(line, file=sys.stderr if args.quiet else sys.stdout)
    if damage:
        print(f"original run: {damage}", file=sys.stderr)
        return rc or 2
    return rc
