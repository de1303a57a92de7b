"""Per-frame metadata in the run (issue 36, finding 9): each stage's frame counters and
timestamps (and the device temperature where the source reports one) in the stage's HDF5,
reached from report.h5's /stages -- on the wire bench the counters are the USB header's."""

from __future__ import annotations

from pathlib import Path

import h5py
import json

import numpy as np

from ares.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _scan(tmp_path: Path, system: str | Path) -> Path:
    p = tmp_path / "meta.xml"
    p.write_text(f"""<?xml version="1.0"?>
<scan name="meta" version="1">
  <system href="{ROOT / 'protocols' / system}"/>
  <settings><set quantity="exposure" value="0.01"/></settings>
  <frames>3</frames>
  <stages>
    <stage name="dark" scene="dark"/>
    <sweep name="ptc" scene="flat"><axis quantity="light"><values>1e5</values></axis></sweep>
    <stage name="warm" scene="dark"><set quantity="temperature" value="30"/></stage>
  </stages>
  <output pdf="false"/>
</scan>
""")
    return p


def test_usb_frame_counters_and_timestamps_per_stage_in_report_h5(tmp_path):
    """... and the device's own time stamps where its header carries them (``header="ares40"``,
    issue 49): the device clock at each frame's exposure start, beside the host's arrival time --
    here with the grabber in hardware-trigger mode, a frame per edge of the emulated bench's pulse
    generator, which skips one edge (the read times out; the stage is grabbed again)."""
    out = tmp_path / "run"
    system = tmp_path / "sim_wire_ares40.xml"
    text = (ROOT / "protocols" / "sim_wire.xml").read_text().replace('header="ares32"', 'header="ares40"')
    system.write_text(text.replace('      <control when="stop" request_type="0x40" request="0xB2" value="0"/>',
                                   '      <control when="stop" request_type="0x40" request="0xB2" value="0"/>\n'
                                   '      <control when="trigger_mode" request_type="0x40" request="0xC1" value="mode"/>\n'
                                   '      <trigger mode="hardware" timeout_ms="100"/>'))
    scan = _scan(tmp_path, system)
    scan.write_text(scan.read_text().replace("<frames>3</frames>", '<frames on_loss="regrab">3</frames>'))
    assert main(["run", str(scan), "--out", str(out), "-q", "--sim-fault", "usb_trigger_missing_at=7"]) == 0
    assert any(json.loads((out / "stages" / f"{k:04d}.json").read_text()).get("frames_lost") for k in range(3))
    with h5py.File(out / "report.h5", "r") as f:
        counters = [list(f[f"stages/{k:04d}/frame_counter"][()]) for k in range(3)]
        stamps = np.concatenate([f[f"stages/{k:04d}/frame_timestamp"][()] for k in range(3)])
        device = [f[f"stages/{k:04d}/frame_device_timestamp"][()] for k in range(3)]
        assert all(np.allclose(np.diff(d), 0.01) for d in device)  # one 10 ms exposure apart, on the device clock
        assert f["stages/0000/frame_device_timestamp"].attrs["unit"].startswith("s (the device's own clock")
        assert f["stages/0000/frame_counter"].attrs["unit"].startswith("1 (the device's frame counter")
        assert "frame_temperature" not in f["stages/0000"]  # the USB header carries none
    flat = [c for c in counters]
    st0 = json.loads((out / "stages" / "0000.json").read_text())
    # the frames settling took before the first stage (ares.scan.settling: its record says how many)
    before = sum(r.get("probe_frames", 0) + r.get("discarded", 0)
                 for r in st0.get("settling", {}).values() if isinstance(r, dict) and "changed" in r)
    assert flat[0] == [before, before + 1, before + 2]  # the device counter from the ares40 header, over stages
    assert all(b[0] > a[-1] for a, b in zip(flat, flat[1:])) and all(np.diff(c).tolist() == [1, 1] for c in flat)
    assert np.all(np.diff(stamps) >= 0)


def test_simulator_temperature_per_frame(tmp_path):
    out = tmp_path / "run"
    assert main(["run", str(_scan(tmp_path, "sim_sensor.xml")), "--out", str(out), "-q"]) == 0
    with h5py.File(out / "report.h5", "r") as f:
        t = [f[f"stages/{k:04d}/frame_temperature"][()] for k in (0, 2)]
        assert f["stages/0002/frame_temperature"].attrs["unit"].startswith("C")
    assert np.all(t[0] == t[0][0]) and np.allclose(t[1], 30.0, atol=0.5) and len(t[1]) == 3
