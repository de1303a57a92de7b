"""Cheap simulated sensors to try the production workflow on (``python -m ares.batch.demo
DIR``): for each lot a dark stack per sensor (5 frames of 16 x 16, offset ~ N(200, 2) DN,
pixel temporal noise 3 DN -- ``ares batch`` reports them as the components ``o`` and
``Pt``) across the wafers, with planted truth: sensors whose offset is outside the static
limit (every 23rd), sensors whose temporal noise is 4x (every 19th: an outlier only the
lot's own dynamic PAT limit catches), one unreadable file; and the lot file with the
limits, the PAT screen and the declared bins. ``truth_<lot>.csv`` says what each sensor
was made to be and the bin it belongs in, to check the lot's bins against.

Layout: ``DIR/<lot>.xml``, ``DIR/<lot>/<serial>.npy``, ``DIR/truth_<lot>.csv``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

PER_WAFER_COLS = 10
# planted kind -> (hard bin, soft bin) of the lot file's <bins>
BIN_OF = {"pass": (1, 1), "limit": (2, 20), "outlier": (3, 51), "error": (4, 99)}
LIMITS_AND_BINS = """  <limits>
    <limit quantity="o" min="190" max="250" soft_bin="20"/>
    <pat quantity="Pt" k="6"/>
  </limits>
  <bins>
    <hard number="1" name="good" pass="true"/>
    <hard number="2" name="parametric fail"/>
    <hard number="3" name="outlier"/>
    <hard number="4" name="no data"/>
    <soft number="1" hard="1" name="good" for="pass"/>
    <soft number="20" hard="2" name="offset out of range"/>
    <soft number="51" hard="3" name="noise outlier" for="pat"/>
    <soft number="99" hard="4" name="could not be analysed" for="error"/>
  </bins>
"""


def make_lot(base: Path, n: int, name: str = "P1", wafers: int = 4, seed: int = 2026) -> dict[str, str]:
    """``n`` sensors of lot ``name`` over ``wafers`` wafers and its lot file; {serial: planted
    kind} (pass, limit, outlier, error)."""
    import numpy as np

    base = Path(base)
    rng = np.random.default_rng(seed)
    truth, items = {}, []
    (base / name).mkdir(parents=True, exist_ok=True)
    for i in range(n):
        serial, wafer, k = f"{name}-{i:04d}", f"W{i % wafers + 1}", i // wafers
        kind, offset, noise = "pass", 200 + rng.normal(0, 2), 3.0
        if i % 23 == 5:
            kind, offset = "limit", 300.0
        elif i % 19 == 7:
            kind, noise = "outlier", 12.0
        path = base / name / f"{serial}.npy"
        if i == n - 2:
            kind = "error"
            path.write_bytes(b"\x93NUMPY garbage")
        else:
            np.save(path, np.clip(offset + rng.normal(0, noise, (5, 16, 16)), 0, 65535).astype(np.uint16))
        truth[serial] = kind
        items.append(f'  <item path="{name}/{serial}.npy" sensor="{serial}" wafer="{wafer}" '
                     f'x="{k % PER_WAFER_COLS}" y="{k // PER_WAFER_COLS}"/>')
    (base / f"{name}.xml").write_text(f'<lot name="{name}" version="1">\n' + "\n".join(items) + "\n" +
                                      LIMITS_AND_BINS + "</lot>\n")
    (base / f"truth_{name}.csv").write_text("serial,planted,hard_bin,soft_bin\n" + "".join(
        f"{s},{k},{BIN_OF[k][0]},{BIN_OF[k][1]}\n" for s, k in truth.items()))
    return truth


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m ares.batch.demo", description=__doc__.split("\n\n")[0])
    p.add_argument("dir", help="where the lots go")
    p.add_argument("--sensors", type=int, default=200, help="sensors a lot (default 200)")
    p.add_argument("--wafers", type=int, default=4, help="wafers a lot (default 4)")
    p.add_argument("--lots", type=int, default=1, help="lots P1, P2, ... (default 1)")
    a = p.parse_args(argv)
    if a.sensors < 4 or a.wafers < 1 or a.lots < 1:
        p.error("--sensors must be at least 4, --wafers and --lots at least 1")
    for k in range(1, a.lots + 1):
        truth = make_lot(Path(a.dir), a.sensors, f"P{k}", a.wafers, seed=2026 + k)
        print(f"{a.dir}/P{k}.xml: {len(truth)} sensors on {a.wafers} wafers "
              f"({', '.join(f'{sum(v == x for v in truth.values())} {x}' for x in BIN_OF)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
