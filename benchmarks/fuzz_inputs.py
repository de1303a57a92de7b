"""Fuzz run of every shipped input kind (issue 54): random truncation and byte flips of
scan XML, system XML, frame stacks (.npy, .npz, HDF5, PNG, TIFF), a run directory's stage
JSON and an EMVA 1288 descriptor, each given to the command that reads it. Counts the
outcomes: one sentence and a documented exit code (clean), a traceback (an exception out
of ``ares.cli.main``, or "Traceback" on stderr), a hang (over ``--timeout`` seconds).

    python benchmarks/fuzz_inputs.py [--cases 1000] [--seed 54] [--timeout 60] [--out benchmarks/fuzz.md]

Run in one process (``ares.cli.main`` called per case, its stderr captured): the command's
own work, not 1000 interpreter start-ups. A hang is caught by SIGALRM, which ends the case
with an exception (counted as a hang, then the next case runs).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import random
import shutil
import signal
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DOCUMENTED = {0, 1, 2, 3, 4, 5}  # (130 would be a signal: none is sent here)


class Hang(BaseException):
    pass


def _alarm(signum, frame):
    raise Hang


def mutate(data: bytes, rnd: random.Random) -> bytes:
    """Random truncation, byte flips, or both."""
    how = rnd.choice(("truncate", "flip", "both", "flips"))
    b = bytearray(data)
    if how in ("truncate", "both") and b:
        b = b[:rnd.randrange(len(b))]
    if how in ("flip", "both", "flips") and b:
        for _ in range(1 if how != "flips" else rnd.randint(2, 32)):
            i = rnd.randrange(len(b))
            b[i] = rnd.randrange(256) if rnd.random() < 0.5 else b[i] ^ (1 << rnd.randrange(8))
    return bytes(b)


def make_inputs(work: Path) -> dict:
    """The originals: (kind -> (file to mutate, argv given the mutated file's path))."""
    from ares.cli import main
    from PIL import Image

    rng = np.random.default_rng(54)
    stack = rng.poisson(300, (3, 24, 32)).astype(np.uint16)
    inputs = {}
    np.save(work / "s.npy", stack)
    np.savez_compressed(work / "s.npz", a=stack)
    import h5py

    with h5py.File(work / "s.h5", "w") as f:
        f.create_dataset("x", data=stack, chunks=(1, 24, 32), compression="gzip")
    Image.fromarray(stack[0]).save(work / "s.png")
    Image.fromarray(stack[0]).save(work / "s.tif")
    for suf in ("npy", "npz", "h5", "png", "tif"):
        inputs[f"stack .{suf}"] = (work / f"s.{suf}", lambda p: ["analyze", str(p)])
    inputs["stack .h5"] = (work / "s.h5", lambda p: ["analyze", f"{p}:/x"])
    # scan and system XML: ares validate reads them as ares run would
    (work / "xml").mkdir()
    sys_xml = work / "xml" / "sim_small.xml"
    sys_xml.write_bytes((ROOT / "fixtures" / "xml" / "small" / "sim_small.xml").read_bytes())
    scan_xml = work / "xml" / "tiny.xml"
    scan_xml.write_text(TINY)
    inputs["scan XML"] = (scan_xml, lambda p: ["validate", str(p), "--quiet"])
    inputs["system XML"] = (sys_xml, lambda p: ["validate", str(scan_xml), "--quiet"])
    # an EMVA 1288 descriptor (four levels and a dark, 32x24 PNGs)
    (work / "emva").mkdir()
    lines = ["v 3.0", "n 12 32 24"]
    for k, (photons, level) in enumerate(((0, 100), (2000, 400), (5000, 850), (9000, 1300), (14000, 1900))):
        lines.append(f"d 1000" if photons == 0 else f"b 1000 {photons}")
        for j in range(2):
            Image.fromarray(rng.poisson(level, (24, 32)).astype(np.uint16)).save(work / "emva" / f"{k}_{j}.png")
            lines.append(f"i {k}_{j}.png")
    (work / "emva" / "data.txt").write_text("\n".join(lines) + "\n")
    inputs["EMVA descriptor"] = (work / "emva" / "data.txt", lambda p: ["emva", str(p)])
    # a run directory's stage JSON: ares report reads the directory (and checks it)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", str(scan_xml), "--out", str(work / "run"), "--quiet"]) == 0
    inputs["stage JSON"] = (work / "run" / "stages" / "0001.json",
                            lambda p: ["report", str(p.parent.parent), "--csv", str(p.parent.parent / "tables")])
    return inputs


TINY = """<?xml version="1.0" encoding="UTF-8"?>
<scan name="tiny" version="1">
  <system href="sim_small.xml"/>
  <settings><set quantity="exposure" value="0.01"/><set quantity="analog_gain" value="1"/></settings>
  <frames>2</frames>
  <stages>
    <stage name="dark" scene="dark"/>
    <sweep name="ptc" scene="flat" dark="matched">
      <axis quantity="light"><log start="10000" stop="3000000" points="3"/></axis>
    </sweep>
  </stages>
  <analyses><analysis name="ptc"/></analyses>
  <output pdf="false"/>
</scan>
"""


def run_case(argv: list[str], timeout: float) -> tuple[str, int | None, str, float]:
    """(outcome, exit code, stderr, seconds): clean / traceback / hang / exit code."""
    from ares.cli import main

    err, out = io.StringIO(), io.StringIO()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    t0 = time.monotonic()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            rc = main(argv)
    except Hang:
        return "hang", None, err.getvalue(), time.monotonic() - t0
    except SystemExit as exc:  # argparse
        rc = exc.code if isinstance(exc.code, int) else 2
    except BaseException:  # noqa: BLE001 -- the point: anything out of main is a traceback
        return "traceback", None, traceback.format_exc(), time.monotonic() - t0
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    s = err.getvalue()
    if "Traceback" in s:
        return "traceback", rc, s, time.monotonic() - t0
    if rc not in DOCUMENTED:
        return "undocumented exit", rc, s, time.monotonic() - t0
    return "clean", rc, s, time.monotonic() - t0


def main_() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=54)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds after which a case is a hang")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "fuzz.md"))
    a = ap.parse_args()
    rnd = random.Random(a.seed)
    work = Path(tempfile.mkdtemp(prefix="ares_fuzz_"))
    try:
        inputs = make_inputs(work)
        kinds = sorted(inputs)
        originals = {k: inputs[k][0].read_bytes() for k in kinds}
        tally = {k: {} for k in kinds}
        unmutated = {}  # each original as its command reads it (the baseline: exit 0)
        for k in kinds:
            outcome, rc, err, _ = run_case(inputs[k][1](inputs[k][0]), a.timeout)
            unmutated[k] = f"exit {rc}" if outcome == "clean" else f"{outcome}: {err.strip()[-200:]}"
            if k == "stage JSON":
                shutil.rmtree(inputs[k][0].parent.parent / "tables", ignore_errors=True)
        bad, slowest = [], {k: 0.0 for k in kinds}
        t_all = time.monotonic()
        for i in range(a.cases):
            kind = kinds[i % len(kinds)]
            path, argv = inputs[kind]
            path.write_bytes(mutate(originals[kind], rnd))
            if kind == "stage JSON":
                shutil.rmtree(path.parent.parent / "tables", ignore_errors=True)
            outcome, rc, err, secs = run_case(argv(path), a.timeout)
            path.write_bytes(originals[kind])
            key = outcome if outcome != "clean" else f"exit {rc}"
            tally[kind][key] = tally[kind].get(key, 0) + 1
            slowest[kind] = max(slowest[kind], secs)
            if outcome != "clean":
                bad.append((i, kind, outcome, err.strip().splitlines()[-1:] if err else []))
                print(f"case {i} ({kind}): {outcome}: {err.strip().splitlines()[-1:] if err else ''}", file=sys.stderr)
        total = time.monotonic() - t_all
    finally:
        shutil.rmtree(work, ignore_errors=True)
    n_tb = sum(1 for b in bad if b[2] == "traceback")
    n_hang = sum(1 for b in bad if b[2] == "hang")
    lines = ["| input kind | unmutated | cases | outcomes of the mutated | slowest case (s) |", "|---|---|---|---|---|"]
    for k in kinds:
        lines.append(f"| {k} | {unmutated[k]} | {sum(tally[k].values())} | "
                     f"{', '.join(f'{o}: {n}' for o, n in sorted(tally[k].items()))} | {slowest[k]:.1f} |")
    print("\n".join(lines))
    print(f"{a.cases} cases in {total:.0f} s: {n_tb} traceback(s), {n_hang} hang(s), "
          f"{len(bad) - n_tb - n_hang} undocumented exit code(s)")
    if a.out:
        Path(a.out).write_text(REPORT.format(cases=a.cases, seed=a.seed, timeout=a.timeout, table="\n".join(lines),
                                             total=total, tb=n_tb, hang=n_hang, other=len(bad) - n_tb - n_hang,
                                             bad="\n".join(f"- case {i} ({k}): {o}: {' '.join(e)}"
                                                           for i, k, o, e in bad) or "- none",
                                             date=time.strftime("%Y-%m-%d")))
    return 1 if bad else 0


REPORT = """# Fuzz run of the shipped input kinds (issue 54)

`python benchmarks/fuzz_inputs.py --cases {cases} --seed {seed} --timeout {timeout:g}` ({date}):
random truncation and byte flips (one, or 2-32) of each input kind, given to the command
that reads it (`ares analyze` for stacks, `ares validate` for scan and system XML, `ares emva`
for a descriptor, `ares report` for a run directory whose stage JSON was mutated), in one
process. "exit N": one sentence on stderr and a documented exit code; a traceback is an
exception out of `ares.cli.main` or "Traceback" on stderr; a hang is a case over {timeout:g} s.

{table}

{cases} cases in {total:.0f} s: **{tb} traceback(s), {hang} hang(s), {other} undocumented exit code(s)**.

Not clean:
{bad}

Exit 0 on a mutated input is a mutation that left the input valid (a flipped digit in a
number, a truncation inside trailing whitespace or a comment) or, for a stage JSON, a
report written from a directory whose damage `ares report` notes (its check of the stage
hashes says which file differs).
"""


if __name__ == "__main__":
    sys.exit(main_())
