"""Trigger and timing on the USB grabber (issue 49): ``<trigger mode="software|hardware"
strobe="exposure">`` is honoured by the host (the trigger mode and strobe requests at open, a
software trigger before every frame, a hardware trigger's wait in the read timeout) and by the
emulated grabber, which behaves like the device: it free-runs at power-up, and once told
"hardware" no frame arrives until its trigger line fires; ``header="ares40"`` carries the
device's clock at each frame's exposure start, recorded as the frame's device time stamp."""

from __future__ import annotations

import numpy as np
import pytest

from ares.errors import FrameLost, InputError
from ares.protocol import load_system, save_system
from ares.rig.factory import build_bench
from wire_small import small_wire

CONTROLS = '''      <control when="stop" request_type="0x40" request="0xB2" value="0"/>
      <control when="trigger_mode" request_type="0x40" request="0xC1" value="mode"/>
      <control when="strobe" request_type="0x40" request="0xC2" value="strobe"/>
      <control when="trigger" request_type="0x40" request="0xC3" value="0"/>
      {trigger}'''


def _system(tmp_path, trigger: str):
    p = small_wire(tmp_path)
    text = p.read_text().replace('header="ares32"', 'header="ares40"')
    text = text.replace('      <control when="stop" request_type="0x40" request="0xB2" value="0"/>',
                        CONTROLS.format(trigger=trigger))
    p.write_text(text)
    return load_system(p)


def test_hardware_trigger_no_frame_until_the_line_fires(tmp_path):
    sy = _system(tmp_path, '<trigger mode="hardware" line="2" edge="falling" timeout_ms="500" strobe="exposure"/>')
    assert sy.usb_grabber.trigger.mode == "hardware" and sy.usb_grabber.trigger.line == 2
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").usb_grabber == sy.usb_grabber
    bench = build_bench(sy, seed=1)
    try:
        grabber = bench.emulators["usb"]
        assert grabber.line.generator  # the wire bench wires a pulse generator to the line: switched off here
        grabber.line.generator = False
        assert (grabber.trigger_mode, grabber.trigger_input, grabber.falling) == (2, 2, True)  # told at open
        assert bench.frames.timeout_ms == 2000 + 500  # the read waits for the edge too
        with pytest.raises(FrameLost, match=r"timeout; no edge on hardware trigger line 2\?"):
            list(bench.frames.grab(2))
        grabber.line.fire(3)
        frames = list(bench.frames.grab(3))
        assert len(frames) == 3 and grabber.line.edges == 0
        stamps = [f.meta["device_timestamp_s"] for f in frames]  # the device clock at exposure start
        assert np.allclose(np.diff(stamps), 0.01)  # one exposure (10 ms) apart
        assert [w for _, w in grabber.strobes] == pytest.approx([0.01] * 3)  # strobe high while exposing
        assert [s for s, _ in grabber.strobes] == pytest.approx(stamps)
    finally:
        bench.close()


def test_software_trigger_one_frame_per_trigger_request(tmp_path):
    bench = build_bench(_system(tmp_path, '<trigger mode="software"/>'), seed=1)
    try:
        grabber = bench.emulators["usb"]
        assert len(list(bench.frames.grab(4))) == 4
        assert sum(1 for r in grabber.requests if r[1] == 0xC3) == 4 and grabber.line.fired == 0
        assert grabber.strobes == []  # strobe off
    finally:
        bench.close()


def test_a_trigger_without_its_request_is_one_sentence(tmp_path):
    p = small_wire(tmp_path)
    p.write_text(p.read_text().replace('      <control when="stop" request_type="0x40" request="0xB2" value="0"/>',
                                       '      <control when="stop" request_type="0x40" request="0xB2" value="0"/>\n'
                                       '      <trigger mode="software"/>'))
    with pytest.raises(InputError, match=r":\d+: <trigger mode='software' strobe='off'> needs the grabber's "
                                         r"<control when='trigger_mode'>"):
        load_system(p)
