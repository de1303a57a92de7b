"""``ares rerun RUN_DIR``: repeat a run exactly from what its directory holds
(verbatim scan and system XML, checked against their SHA-256, seed and frame override)."""

from __future__ import annotations

from pathlib import Path

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
    out = args.out
    if out is None:
        base = Path(args.run_dir).resolve()
        k = 1
        while (out := base.with_name(f"{base.name}_rerun{k}")).exists():
            k += 1
    return execute(rec.scan, args, seed=rec.meta.get("seed"), frames=rec.meta.get("frames_override"),
                   argv=["rerun", str(args.run_dir)], out_dir=out)
