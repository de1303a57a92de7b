"""Trigger, strobe and chunk time stamps on a GenICam camera (issue 49), against an emulated camera
(``ares.hardware.emulators.genicam_device``) that behaves as one: free run until told otherwise,
with TriggerMode On a buffer only per TriggerSoftware or per edge on the trigger line, the strobe
line driven while exposing, and the device clock at exposure start in the chunk data."""

from __future__ import annotations

import numpy as np
import pytest

from ares.errors import FrameLost
from ares.hardware.emulators.genicam_device import EmulatedCamera
from ares.hardware.genicam import GenICamCamera, GenICamFrameSource
from ares.protocol import load_system, save_system
from ares.sim import make_sim_bench
from ares.sim.params import SensorParams

SYSTEM = """<?xml version="1.0"?>
<system name="gev" version="1">
  <sensor name="cam"><array rows="16" cols="24"/><cfa pattern="mono"/><adc bits="12"/></sensor>
  <controls exposure="exposure"/>
  <devices>
    <genicam name="cam" cti="genicam:viky.cti" timeout_ms="200" chunk_timestamp="true">
      <feature field="exposure" node="ExposureTime" scale="1e-6" unit="s" min="1e-5" max="1"/>
      {trigger}
    </genicam>
  </devices>
</system>
"""


def _camera(tmp_path, trigger: str):
    p = tmp_path / "gev.xml"
    p.write_text(SYSTEM.format(trigger=trigger))
    sy = load_system(p)
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").genicam == sy.genicam
    bench = make_sim_bench(SensorParams(rows=16, cols=24, adc_bits=12), seed=2)
    emu = EmulatedCamera(bench.frames, bench.registers, readout_s=0.002)
    cam = GenICamCamera.attach(sy.genicam, emu)
    return GenICamFrameSource(cam, (16, 24), 12), emu, bench


def test_hardware_trigger_strobe_and_chunk_timestamps(tmp_path):
    src, emu, _ = _camera(tmp_path, '<trigger mode="hardware" line="1" edge="falling" timeout_ms="300" '
                                    'strobe="exposure" strobe_line="2"/>')
    st = emu.state
    assert (st["TriggerMode"], st["TriggerSource"], st["TriggerActivation"]) == ("On", "Line1", "FallingEdge")
    assert src.timeout_ms == 200 + 300
    with pytest.raises(FrameLost, match=r"timeout; no edge on hardware trigger line 1\?"):
        list(src.grab(1))  # no edge: no frame
    emu.lines[1].fire(3)
    frames = list(src.grab(3))
    stamps = [f.meta["device_timestamp_s"] for f in frames]  # the chunk's: exposure start, not transfer end
    assert np.allclose(np.diff(stamps), 0.01) and stamps[0] == pytest.approx(emu.strobes[0][1])
    assert [(line, w) for line, _, w in emu.strobes] == [("Line2", pytest.approx(0.01))] * 3


def test_software_trigger_one_buffer_per_trigger(tmp_path):
    src, emu, _ = _camera(tmp_path, '<trigger mode="software"/>')
    assert len(list(src.grab(4))) == 4 and emu.frame_id == 4 and not emu.strobes
    assert all(line.fired == 0 for line in emu.lines)
