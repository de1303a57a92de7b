"""Suspenders (issue 10): a scan's <suspend> conditions pause acquisition while the chamber or
the light source is out of tolerance, and resume it by itself when they clear; the pause is
recorded; a pause that never clears is a hardware error; a stop ends it."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest

from ares.sim.from_system import sim_params
from ares.protocol import load_scan, save_scan
from ares.scan import Runner
from ares.sim.bench import SimChamber, make_sim_bench

ROOT = Path(__file__).resolve().parents[1]
SCAN = """<?xml version="1.0" encoding="UTF-8"?>
<scan name="suspend_small" version="1">
  <system href="{system}"/>
  <settings><set quantity="exposure" value="0.01"/><set quantity="temperature" value="25"/></settings>
  <frames>6</frames>
  <stages>
    <stage name="dark" scene="dark"/>
    <stage name="flat" scene="flat" dark="matched"><set quantity="light" value="100000"/></stage>
  </stages>
  <suspend poll_s="0.001" hold_s="0" timeout_s="{timeout}">
    <condition quantity="temperature" tolerance="0.5"/>
    <condition quantity="light" tolerance="0.02"/>
  </suspend>
</scan>
"""


class DriftingChamber(SimChamber):
    """Reads ``drift`` C off its set point on reads number ``start`` .. ``stop - 1``; with
    ``when_lit``, only while the bench's light is on (so in a lit stage however many reads
    the dark stage took: their number depends on the machine's speed)."""

    def __init__(self, start: int, stop: float, drift: float = 3.0, when_lit: bool = False):
        super().__init__()
        self.reads, self.start, self.stop, self.drift = 0, start, stop, drift
        self.when_lit, self.light = when_lit, None
        self.drifting = threading.Event()

    def get_temperature(self) -> float:
        self.reads += 1
        off = self.start <= self.reads < self.stop and (not self.when_lit or self.light.get_level() > 0)
        if off:
            self.drifting.set()
        return super().get_temperature() + (self.drift if off else 0.0)


def scan_file(tmp_path, timeout=600):
    p = tmp_path / "scan.xml"
    p.write_text(SCAN.format(system=ROOT / "fixtures" / "xml" / "small" / "sim_small.xml", timeout=timeout))
    return load_scan(p)


def run_with(tmp_path, chamber, timeout=600, stopper=None):
    scan = scan_file(tmp_path, timeout)
    bench = make_sim_bench(sim_params(scan.system), seed=3)
    bench.chamber, chamber.light = chamber, bench.light
    runner = Runner(scan, bench=bench, out_dir=tmp_path / "run")
    if stopper:
        threading.Thread(target=stopper, args=(runner,), daemon=True).start()
    return runner.run(), tmp_path / "run"


def stage_json(d: Path, i: int) -> dict:
    return json.loads((d / "stages" / f"{i:04d}.json").read_text())


def test_drift_pauses_the_stage_and_it_is_acquired_again(tmp_path):
    out, d = run_with(tmp_path, DriftingChamber(start=4, stop=9))
    assert out.status == "done" and len(out.stages) == 2
    sus = [s for i in range(2) for s in stage_json(d, i).get("suspensions", [])]
    assert len(sus) == 1 and sus[0]["reason"] == "chamber at 28 C, set point 25 +/- 0.5 C"
    for i in range(2):  # the stage that was suspended still has its full stack, all in tolerance
        assert stage_json(d, i)["views"]["full"]["level"]["n_frames"] == 6


def test_a_condition_that_never_clears_is_a_hardware_error(tmp_path):
    from ares.errors import HardwareError

    with pytest.raises(HardwareError, match=r"stage 'flat': suspended for 0.05 s and the condition did not clear "
                                            r"\(chamber at 28 C, set point 25 \+/- 0.5 C"):
        run_with(tmp_path, DriftingChamber(start=0, stop=float("inf"), when_lit=True), timeout=0.05)
    meta = json.loads((tmp_path / "run" / "run.json").read_text())
    assert meta["status"] == "failed" and stage_json(tmp_path / "run", 0)["name"] == "dark"  # the dark is kept


def test_stop_ends_a_suspension(tmp_path):
    ch = DriftingChamber(start=4, stop=float("inf"))
    out, d = run_with(tmp_path, ch, stopper=lambda r: ch.drifting.wait(600) and r.stop())
    assert out.status == "stopped"
    assert json.loads((d / "run.json").read_text())["status"] == "stopped"


def test_suspend_round_trips_through_xml(tmp_path):
    scan = scan_file(tmp_path)
    save_scan(scan, tmp_path / "again.xml")
    again = load_scan(tmp_path / "again.xml")
    assert again.suspend == scan.suspend and again.suspend.conditions == (("temperature", 0.5), ("light", 0.02))


def device_scan(tmp_path, timeout=600):
    p = tmp_path / "dev.xml"
    p.write_text(SCAN.format(system=ROOT / "fixtures" / "xml" / "small" / "sim_small.xml", timeout=timeout).replace(
        '<condition quantity="light" tolerance="0.02"/>', '<condition quantity="device"/>'))
    return load_scan(p)


def test_an_unplugged_grabber_is_waited_for_and_the_stage_acquired_again(tmp_path):
    scan = device_scan(tmp_path)
    out = Runner(scan, out_dir=tmp_path / "run", seed=3,
                 faults={"disconnect_after_frames": 9, "reconnect_after_polls": 3}).run()
    assert out.status == "done" and len(out.stages) == 2
    sus = [s for i in range(2) for s in stage_json(tmp_path / "run", i).get("suspensions", [])]
    assert [s["reason"] for s in sus] == ["sim grabber: device disconnected after 9 frames"]
    assert all(stage_json(tmp_path / "run", i)["views"]["full"]["level"]["n_frames"] == 6 for i in range(2))


def test_a_grabber_that_never_returns_fails_the_run_with_one_sentence(tmp_path):
    from ares.errors import DeviceGone

    scan = device_scan(tmp_path, timeout=0.05)
    with pytest.raises(DeviceGone, match=r"device disconnected after 9 frames; not back after 0.05 s"):
        Runner(scan, out_dir=tmp_path / "run", seed=3, faults={"disconnect_after_frames": 9}).run()
    assert json.loads((tmp_path / "run" / "run.json").read_text())["status"] == "failed"
