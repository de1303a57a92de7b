"""Serial (issue 36, finding 7) over pyserial with the ``aresemu://`` port: a reply that
arrives after its command timed out waits in the input buffer; the host flushes it before
the next command, so it cannot answer that one ("reply 'OK' to 'LEVEL?' is not a number")."""

from __future__ import annotations

from pathlib import Path

import pytest

from ares.errors import DeviceGone, HardwareError
from ares.hardware.emulators.serial_device import EmulatedInstrument, register, unregister
from ares.hardware.serial_instruments import SerialLightSource
from ares.protocol import load_system
from ares.sim.bench import SimLightSource

ROOT = Path(__file__).resolve().parents[1]


def test_a_late_reply_does_not_answer_the_next_command():
    cfg = load_system(ROOT / "protocols" / "sim_wire.xml").light_source
    emu = EmulatedInstrument(SimLightSource(), {"light_late_at": 1})  # (command 0: *IDN? at open)
    register("led", emu)
    try:
        led = SerialLightSource.open(cfg)
        with pytest.raises(HardwareError, match=r"no reply to 'LEVEL 1000.0' within 1 s \(timeout") as e:
            led.set_level(1000.0)  # the device did it, but its 'OK' comes late
        assert not isinstance(e.value, DeviceGone)  # silent, not unplugged: reopening the port would not help
        assert led.get_level() == 1000.0  # not "reply 'OK' to 'LEVEL?' is not a number"
        led.close()
    finally:
        unregister("led", emu)
