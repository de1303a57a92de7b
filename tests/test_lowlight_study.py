"""Studies of the low-light analyses at the issue's sizes (``@pytest.mark.study``: ``make bench-quick``):
RTN over 1000 frames (benchmarks/rtn.md's configuration), the activation-energy map of the shipped
``scans/dark_temperature.xml`` against the simulator's, the Fe-55 gain over seeds."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.study
def test_rtn_1000_frames_recall_precision_amplitude_dwell():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_rtn import one

    r = one(seed=3, frames=1000)
    assert r["recall"] >= 0.95 and r["precision"] >= 0.95
    assert r["amp_5"] >= 0.95
    # dwell times: within 10 % as often as the trap's true states allow (at 1000 frames ~55 %: SEs of 11-18 %),
    # unbiased, and the reported SEs cover the errors
    assert r["dw_10"] >= r["known_10"] - 0.05 and abs(r["dw_bias"]) < 0.03
    assert r["cov"][2] >= 0.97 and r["cov"][1] >= 0.92 and 0.8 < r["pull_sd"] < 1.2
    assert r["need10"] > 1000  # the median pixel's dwell SE is over 10 %: "needs >= N frames" says so


@pytest.mark.study
def test_shipped_dark_temperature_scan_recovers_the_activation_map(tmp_path):
    import dataclasses

    from ares.protocol import load_scan
    from ares.results.lowlight import run_dark_temperature
    from ares.rundir.record import load_run
    from ares.scan import Runner
    from ares.sim import SimSensor
    from ares.sim.from_system import sim_params

    scan = load_scan(ROOT / "scans" / "dark_temperature.xml")
    scan = dataclasses.replace(scan, output=dataclasses.replace(scan.output, pdf=False, csv=False))
    assert Runner(scan, out_dir=tmp_path / "run").run().status == "done"
    out, maps = run_dark_temperature(load_run(tmp_path / "run"))
    s = SimSensor(sim_params(scan.system), scan.system.simulator.seed)
    truth = s.truth(temperature_c=60)["lowlight"]["arrhenius"]
    rts = np.zeros(maps["activation_ev"].shape, bool)
    r, c = s.patterns.defects.locations("rts")
    rts[r, c] = True  # a telegraph pixel's stage means are not Gaussian about its rate
    pull = ((maps["activation_ev"] - truth["activation_ev"]) / maps["activation_se_ev"])[~rts]
    pull = pull[np.isfinite(pull)]
    assert np.mean(np.abs(pull) < 2) > 0.93 and np.std(pull) < 1.1 and abs(np.mean(pull)) < 0.1
    assert abs(out["pixels"]["median_activation_ev"]["value"] - 0.65) < 0.005


@pytest.mark.study
def test_fe55_simulator_gain_over_seeds():
    from ares.analysis.lowlight import fe55
    from ares.sim import SensorParams, SimSensor

    p = SensorParams(rows=96, cols=96).replace(xray_events_per_frame=40)
    for seed in range(5):
        s = SimSensor(p, seed=seed)
        frames = s.render(60, exposure_s=0.01, dark=True, temperature_c=-30)
        ev = fe55.find_events(frames)
        r = fe55.analyse(ev.signal_dn, -30.0, ev)
        g = r["gain_e_per_dn"]
        assert abs(g.value / s.truth(temperature_c=-30)["lowlight"]["xray"]["gain_e_per_dn"] - 1) < 0.01
