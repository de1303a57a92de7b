"""Issue 34: the PRNU/DSNU mask holds every defect class any stage finds.

The mask used to come from the first dark stage alone, so dead pixels (visible only in
light) stayed in the masked PRNU -- 27 SE above the simulator's truth on the main job.
Here a small photon-transfer scan runs on a simulated sensor with 1 % dead pixels (the
dead response 0.3 of a normal pixel's); the decomposition's masked gain non-uniformity
Pg must be within 3 SE of the realized (defect-free) truth, every dead pixel must be in
the mask the mid-level stage was taken with, and the unmasked Pg must be far off (so the
check can fail).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from ares.hardware.factory import sim_params
from ares.protocol import load_scan
from ares.scan import Runner
from ares.scan.apply import apply_settings
from ares.sim import make_sim_bench

ROOT = Path(__file__).resolve().parents[1]
SEED = 3


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    scan = load_scan(ROOT / "fixtures" / "xml" / "small" / "ptc_small.xml")
    params = dataclasses.replace(sim_params(scan.system), dead_rate_ppm=10_000)
    bench = make_sim_bench(params, SEED)
    out = tmp_path_factory.mktemp("maskflat") / "run"
    outcome = Runner(scan, bench=bench, out_dir=out, seed=SEED, frames=16).run()
    assert outcome.status == "done", outcome.message
    rd = Path(outcome.run_dir)
    res = json.loads((rd / "scan_results.json").read_text())["analyses"]
    stages = [json.loads(p.read_text()) for p in sorted((rd / "stages").glob("*.json"))]
    return scan, bench, rd, res, stages


def _truth(scan, bench, settings):
    apply_settings(bench, scan.system, settings)
    s = bench.frames.settings()
    s.pop("test_mode")
    s.pop("streaming")
    s.pop("photon_flux")
    return bench.info["sensor"].truth(photon_flux=settings.get("light", 0.0), **s)


def test_masked_prnu_within_se_of_truth_with_dead_pixels_masked(run):
    scan, bench, rd, res, stages = run
    d = res["decomposition"]
    mid = next(s for s in stages if s["name"] == d["stage"])
    t = _truth(scan, bench, mid["settings"])
    real = t["realized"]["Pg"]
    pg = d["components"]["Pg"]
    assert "flat stage" in d["mask_source"], d["mask_source"]
    assert abs(pg["value"] - real) <= 3 * pg["se"], (pg, real)
    un = d["components_unmasked"]["Pg"]
    assert un["value"] - real > 5 * un["se"], (un, real)
    # every dead pixel is in the mask in force for the mid-level stage (the latest stored
    # at or before it)
    mask = None
    for st in stages:
        if st["index"] > mid["index"]:
            break
        with h5py.File(rd / "stages" / f"{st['index']:04d}.h5") as f:
            if "defect_mask" in f:
                mask = f["defect_mask"][()].astype(bool)
    r, c = t["defects"]["dead"]
    assert r.size > 0 and mask[r, c].all()
    assert int(mask.sum()) == d["masked_pixels"]
