"""The dark current on a bench whose black level drifts (``ares.sim.drift``), against the
simulator's truth over seeds: the dark sweep of ``scans/dark_current.xml`` (8 exposures 0.01 -
1 s, 16 frames, 40 C) on a 32x48 sensor, in increasing and in shuffled order (``<axis
order="shuffled">``) and increasing between two reference darks at 0.01 s (bracketed), without a drift, with a die warm-up and with a linear drift. Before: the
fit on the levels and their frames' scatter (no times); after: the drift fitted beside the rate
on every frame's readout time (``ares.analysis.ptc.dark_drift``). A "wrong ok" is a rate
reported "ok" more than 3 SE from its truth.

    python benchmarks/bench_dark_drift.py [SEEDS]     # writes dark_drift.md (default 40 seeds)
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ares.analysis.ptc.dark_current import dark_current
from ares.protocol import load_scan
from ares.rig.factory import build_bench
from ares.scan import Runner

ROOT = Path(__file__).resolve().parents[1]
OUT = Path(__file__).with_name("dark_drift.md")
AXIS = '<axis quantity="exposure"{}><linear start="0.01" stop="1.0" points="8"/></axis>'
ORDERS = {"increasing": AXIS.format(""), "shuffled": AXIS.format(' order="shuffled"'),
          "bracketed": '<axis quantity="exposure"><values>0.01 ' + " ".join(f"{x:.6g}" for x in np.linspace(0.01, 1, 8))
          + " 0.01</values></axis>"}  # increasing, with a reference dark at 0.01 s before and after
CASES = [("none", {}), ("warm-up 3 DN, tau 100 s", {"offset_warmup_dn": 3.0, "offset_warmup_tau_s": 100.0}),
         ("warm-up 0.5 DN, tau 300 s", {"offset_warmup_dn": 0.5, "offset_warmup_tau_s": 300.0}),
         ("linear 0.005 DN/s", {"offset_drift_dn_per_s": 0.005})]


def scan_file(tmp: Path, params: dict, axis: str) -> Path:
    text = (ROOT / "protocols" / "sim_sensor.xml").read_text().replace('rows="480" cols="640"', 'rows="32" cols="48"')
    text = text.replace('name="rows" type="int" value="480"', 'name="rows" type="int" value="32"')
    text = text.replace('name="cols" type="int" value="640"', 'name="cols" type="int" value="48"')
    text = text.replace("</simulator>", "".join(f'<param name="{k}" type="float" value="{v}"/>'
                                                for k, v in params.items()) + "</simulator>")
    (tmp / "sys.xml").write_text(text)
    p = tmp / "scan.xml"
    p.write_text(f"""<?xml version="1.0"?>
<scan name="dark_drift" version="1"><system href="{tmp / 'sys.xml'}"/>
<settings><set quantity="temperature" value="40"/><set quantity="analog_gain" value="1"/></settings>
<frames>16</frames><stages><sweep name="dark" scene="dark">{axis}
</sweep></stages><analyses><analysis name="dark_current"/></analyses>
<output pdf="false" csv="false" hdf5="false"/></scan>""")
    return p


def one(scan_path: Path, seed: int) -> tuple:
    """(z before, verdict before, z after, verdict after, SE after / SE before) of one seed's run."""
    s = load_scan(scan_path)
    bench = build_bench(s.system, seed=seed)
    out = Runner(s, bench=bench).run()
    t = bench.info["sensor"].truth(exposure_s=1.0, temperature_c=40.0)
    truth = t["G"] * float(t["maps"]["dark_e_per_s"].mean())
    lv = [st["views"]["full"]["level"] for st in out.stages]
    b = dark_current([st["settings"]["exposure"] for st in out.stages], [x["mean_dn"] for x in lv], math.nan,
                     frame_means=[x["frame_means"] for x in lv]).rate_dn_per_s
    a = out.scan_results["dark_current"]["rate_dn_per_s"]
    return (b.value - truth) / b.se, b.verdict, (a["value"] - truth) / a["se"], a["verdict"], a["se"] / b.se


NOTE = """Read: a warm-up that moves the black level by 3 DN over the sweep was a dark current 7.8 SE off,
"ok", on every seed in increasing order; it is now "drift not separated" on every seed (the fitted
parabola brings it to +0.4 SE median, with an SE 1.9x larger -- but only as far as the curve measured
inside the stacks holds: not "ok"). In shuffled order the rate was already unbiased (the drift
scattered the levels and the SE from their residuals covered it); the drift fit keeps it unbiased
and shrinks the SE 16x. Bracketed by two reference darks the increasing sweep is "ok" and right
(+0.0 SE median, 0 wrong ok), with the SE 8x smaller than before. A drift below the frames' detection limit
(F-test p < 0.01 on their scatter: here ~0.008 DN/s, 2.6 x its SE of 0.003) in increasing order --
linear 0.005 DN/s -- moved the rate by ~6 SE unseen (wrong ok 75 %, 93 % before the drift fit).
A test passed is not a drift excluded: where no drift is kept, the rate's SE now holds the drift
the frames cannot exclude (its SE x the clock seconds per second of exposure the order puts on the
slope): 0 wrong ok in every row, at the price of an SE 3.7x larger in increasing order (1.16x
bracketed, 1.00x shuffled, where the order puts no clock on the slope). So the shipped
scans/dark_current.xml takes its exposures in shuffled order. (A 3 DN warm-up also trips the runner's stack-trend
check on 1 of 40 seeds in two of the orders: "not settled".)"""


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    t0 = time.time()
    rows = []
    for name, params in CASES:
        for order, axis in ORDERS.items():
            with tempfile.TemporaryDirectory() as tmp:
                p = scan_file(Path(tmp), params, axis)
                r = [one(p, seed) for seed in range(1, seeds + 1)]
            zb, vb, za, va, ratio = (np.array(x) for x in zip(*r))
            ok = va == "ok"
            rows.append(f"| {name} | {order} | {np.median(zb):+.1f} | "
                        f"{np.mean((vb == 'ok') & (abs(zb) > 3)):.2f} | {np.median(za):+.1f} | "
                        f"{np.mean(ok & (abs(za) > 3)):.2f} | {np.mean(~ok):.2f} | "
                        f"{np.mean(abs(za[ok]) <= 3) if ok.any() else float('nan'):.2f} | {np.median(ratio):.2f} |")
            print(rows[-1], flush=True)
    OUT.write_text("\n".join([
        "# Dark current on a drifting bench: before and after the drift fit", "",
        f"`python benchmarks/bench_dark_drift.py {seeds}` ({seeds} seeds each, {time.time() - t0:.0f} s). The dark "
        "sweep of scans/dark_current.xml (8 exposures 0.01 - 1 s linear, 16 frames, 40 C, ~65 s of bench clock) on "
        "a 32x48 simulator (bracketed: increasing, with a reference dark at 0.01 s before and after); truth: G x the mean pixel dark current (~2.5 DN/s). z = (rate - truth) / SE. Before: "
        "the fit on the levels and their frames' scatter; after: the drift fitted beside the rate on every frame's "
        "readout time. A wrong ok: verdict ok and |z| > 3.", "",
        "| drift | order | median z before | wrong ok before | median z after | wrong ok after | not ok after | "
        "ok within 3 SE after | SE after / before |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|", *rows, "", NOTE]))


if __name__ == "__main__":
    main()
