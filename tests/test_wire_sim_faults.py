"""Issue 49: the simulator's own faults on a wire-emulated system (``--sim-fault
disconnect_after_frames=N`` on protocols/sim_wire.xml) used to raise the simulator's Python
exceptions straight through the USB emulator into the host code -- no byte path saw them, the
host's link statistics stayed clean, and an unplug could never be recovered (the host reopened
a grabber that had never left). They now go through the wire: the grabber vanishes from the
bus (ENODEV) and is found again at the declared search; a frame the sensor cannot read out is
a transfer cut short."""

from __future__ import annotations

import pytest

from ares.errors import DeviceGone, FrameLost
from ares.protocol import load_system
from ares.rig.factory import build_bench
from wire_small import small_wire


def _bench(tmp_path, faults):
    return build_bench(load_system(small_wire(tmp_path)), seed=1, faults=faults)


def test_a_simulated_unplug_is_an_unplug_on_the_wire_and_recovers(tmp_path):
    bench = _bench(tmp_path, {"disconnect_after_frames": 3, "reconnect_after_polls": 2})
    try:
        with pytest.raises(DeviceGone, match=r"USB frame grabber 'grabber'.*device disconnected during frame 3"):
            list(bench.frames.grab(5))
        assert bench.emulators["usb"].connected is False  # the device left the bus
        with pytest.raises(DeviceGone):  # the first search does not find it ...
            bench.reconnect("frames")
        bench.reconnect("frames")  # ... the second does
        assert len(list(bench.frames.grab(4))) == 4
        assert bench.emulators["usb"].handles_closed >= 1  # the old handle was let go
    finally:
        bench.close()


def test_a_frame_the_sensor_cannot_read_out_is_a_short_transfer(tmp_path):
    bench = _bench(tmp_path, {"short_frame_at": 2})
    try:
        with pytest.raises(FrameLost, match=r"frame 2 \(device counter 2\) arrived short") as lost:
            list(bench.frames.grab(4))
        assert lost.value.kind == "short"
        assert bench.frames.link_counters()["short_frames"] == 1  # counted on the link
        assert len(list(bench.frames.grab(3))) == 3  # and the next grab is clean
    finally:
        bench.close()
