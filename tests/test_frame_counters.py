"""Frame counters (issue 36, finding 4; issue 41's dropped first frame) on the emulated USB
grabber of protocols/sim_wire.xml: the device's counter is checked from the very first frame,
updated after a short frame, followed when the device restarts it between grabs, and for a
free-running sensor checked within a grab only (``<usb_grabber counter=...>``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ares.errors import FrameLost
from ares.rig.factory import build_bench
from ares.protocol import load_system

ROOT = Path(__file__).resolve().parents[1]
WIRE = ROOT / "protocols" / "sim_wire.xml"


def _bench(tmp_path=None, counter: str | None = None, **faults):
    path = WIRE
    if counter is not None:  # the same system with the counter declared
        path = tmp_path / "wire.xml"
        path.write_text(WIRE.read_text().replace('header="ares32"', f'header="ares32" counter="{counter}"'))
    return build_bench(load_system(path), seed=1, faults=faults)


def test_a_dropped_first_frame_is_a_gap():
    b = _bench(usb_drop_at=0)
    try:
        with pytest.raises(FrameLost, match=r"1 frame\(s\) dropped before frame 0 \(device counter 1\)") as e:
            list(b.frames.grab(2))
        assert e.value.kind == "dropped" and b.frames.stats()["dropped"] == 1
    finally:
        b.close()


def test_a_short_frame_is_not_counted_dropped_on_the_regrab():
    b = _bench(usb_short_at=1)
    try:
        with pytest.raises(FrameLost, match="arrived short"):
            list(b.frames.grab(3))
        assert len(list(b.frames.grab(3))) == 3  # the re-grab: counters 2, 3, 4 follow the short frame's 1
        assert b.frames.stats()["dropped"] == 0 and b.frames.stats()["short"] == 1
    finally:
        b.close()


def test_a_device_that_restarts_its_counter_between_grabs_is_followed():
    b = _bench()
    try:
        assert len(list(b.frames.grab(3))) == 3
        b.emulators["usb"].counter = 0  # the device restarted its count (power cycle, firmware re-arm)
        assert len(list(b.frames.grab(3))) == 3
        st = b.frames.stats()
        assert st["dropped"] == 0 and st["counter_resets"] == 1
    finally:
        b.close()


def test_per_grab_counter_checks_each_grabs_first_frame(tmp_path):
    b = _bench(tmp_path, "per_grab")
    try:
        usb = b.emulators["usb"]
        usb.counter = 0
        assert len(list(b.frames.grab(2))) == 2
        usb.counter = 1  # the device restarts at every start, and this time frame 0 is lost
        with pytest.raises(FrameLost, match=r"1 frame\(s\) dropped before frame 2"):
            list(b.frames.grab(2))
    finally:
        b.close()


def test_free_running_counter_skips_between_grabs_and_checks_within(tmp_path):
    b = _bench(tmp_path, "free_running", usb_drop_at=10)
    try:
        assert len(list(b.frames.grab(2))) == 2
        b.emulators["usb"].counter += 5  # frames streamed while nobody read: not lost
        assert len(list(b.frames.grab(2))) == 2  # counters 7, 8
        with pytest.raises(FrameLost, match=r"1 frame\(s\) dropped before frame 5"):
            list(b.frames.grab(2))  # counter 10 is dropped: within the grab it is a gap
    finally:
        b.close()


def test_counter_mode_round_trips_through_the_system_xml(tmp_path):
    from ares.protocol import save_system

    s = load_system(_write(tmp_path, "per_grab"))
    save_system(s, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").usb_grabber.counter == "per_grab"


def _write(tmp_path, counter):
    p = tmp_path / "w.xml"
    p.write_text(WIRE.read_text().replace('header="ares32"', f'header="ares32" counter="{counter}"'))
    return p
