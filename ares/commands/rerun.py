"""``ares rerun RUN_DIR``: repeat a run exactly from what its directory holds
(verbatim scan and system XML, checked against their SHA-256, seed and frame override),
then say how many stage results match the original's."""

from __future__ import annotations

import sys
from pathlib import Path

NAME = "rerun"
HELP = "repeat a run from its run directory (same XML, same seed) into a new run directory"


def add_arguments(parser) -> None:
    from ares.commands.run import add_common

    parser.add_argument("run_dir", metavar="RUN_DIR", help="a run directory written by 'ares run'")
    add_common(parser)


def _comparable(stage: dict) -> dict:
    return {k: v for k, v in stage.items() if k not in ("timing",)}


def compare(a, b) -> tuple[int, int, list[str]]:
    """(identical stages, stages compared, names of those that differ)."""
    n = min(len(a.stages), len(b.stages))
    diff = [a.stages[i]["name"] for i in range(n) if _comparable(a.stages[i]) != _comparable(b.stages[i])]
    return n - len(diff), n, diff


def run(args) -> int:
    from ares.commands.run import execute
    from ares.scan import load_run

    rec = load_run(args.run_dir)
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
        return rc
    same, n, diff = compare(rec, new)
    if n and not args.json:
        line = f"reproduced: {same} of {n} stage result(s) identical to {args.run_dir}"
        if diff:
            line += f" (differ: {', '.join(diff[:5])}{' ...' if len(diff) > 5 else ''})"
        print(line, file=sys.stderr if args.quiet else sys.stdout)
    return rc
