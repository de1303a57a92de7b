"""``ares rerun RUN_DIR``: repeat a run exactly from what its directory holds
(verbatim scan and system XML, checked against their SHA-256, seed and frame override),
then say how many stage results (and their arrays, by their recorded SHA-256) match the
original's, and whether the original directory is still as written (``ares.runcheck``: an
incomplete or corrupt original is one sentence on stderr and exit 2, after the rerun)."""

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
    return {k: v for k, v in stage.items() if k not in ("timing", "arrays_sha256", "h5_bytes")}


def compare(a, b) -> tuple[int, int, list[str]]:
    """(identical stages, stages compared, what differs): the stages of ``a`` by index
    against ``b``'s -- each stage's results, and its arrays by the SHA-256 each run recorded
    when it wrote them (``ares.runcheck``), naming the array that differs."""
    theirs = {st["index"]: st for st in b.stages}
    n, diff = 0, []
    for st in a.stages:
        other = theirs.get(st["index"])
        if other is None:
            continue
        n += 1
        what = f"stage {st['index']} '{st['name']}'"
        if _comparable(st) != _comparable(other):
            diff.append(f"{what}: results")
            continue
        ha, hb = st.get("arrays_sha256"), other.get("arrays_sha256")
        if isinstance(ha, dict) and isinstance(hb, dict):
            bad = sorted(k for k in set(ha) | set(hb) if ha.get(k) != hb.get(k))
            if bad:
                diff.append(f"{what}: array{'s' if len(bad) > 1 else ''} {', '.join(bad)}")
    return n - len(diff), n, diff


def original_damage(rec) -> str:
    """"" when the original run directory is as written, else the one sentence of
    ``ares.runcheck`` (incomplete / corrupt: stage N ...)."""
    from ares.runcheck import RunDamaged, check_run

    try:
        check_run(rec.dir, rec.meta, rec.stages, arrays=True)
    except RunDamaged as exc:
        return str(exc)
    return ""


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
