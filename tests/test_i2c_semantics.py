"""I2C semantics (issue 36, finding 6) on the real smbus2 message code with only the kernel
call emulated (``EmulatedSMBus.i2c_rdwr``): a NACK reported as ENXIO -- what i2c-dev returns
while a sensor is busy or powering up -- is retried after a growing pause, not taken for an
unplugged adapter; an adapter that is gone is not retried."""

from __future__ import annotations

import pytest

from ares.errors import DeviceGone
from ares.hardware.emulators.i2c_device import EmulatedSMBus
from ares.hardware.i2c import BACKOFF_S, I2CRegisterBus


class Regs:
    def __init__(self):
        self.v = {0x0000: 0xA2E5}

    def read(self, a):
        return self.v.get(a, 0)

    def write(self, a, value):
        self.v[a] = value


def _bus(**faults):
    pauses = []
    emu = EmulatedSMBus(0x36, Regs(), address_bits=16, value_bits=16, faults=faults)
    bus = I2CRegisterBus(1, 0x36, 16, 16, name="sensor", smbus=emu, retries=3, sleep=pauses.append)
    return bus, emu, pauses


def test_enxio_is_a_nack_retried_with_back_off():
    bus, emu, pauses = _bus(i2c_enxio_at=0, i2c_fault_count=2)
    assert bus.read(0x0000) == 0xA2E5  # two ENXIO, then the answer
    assert emu.transactions == 3 and bus.retried == 1
    assert pauses == [BACKOFF_S, 2 * BACKOFF_S]


def test_enxio_that_persists_names_the_register_after_the_retries():
    bus, emu, pauses = _bus(i2c_enxio_at=0, i2c_fault_count=10)
    with pytest.raises(DeviceGone, match=r"register 0x0010: no acknowledge on write after 4 attempt\(s\)"):
        bus.write(0x0010, 5)
    assert emu.transactions == 4 and pauses == [BACKOFF_S, 2 * BACKOFF_S, 4 * BACKOFF_S]


def test_a_gone_adapter_is_not_retried_and_names_the_register_bus():
    bus, emu, pauses = _bus(i2c_disconnect_at=0)
    with pytest.raises(DeviceGone, match="device gone on read") as e:
        bus.read(0x0000)
    assert e.value.device == "registers" and emu.transactions == 1 and pauses == []


def test_a_busy_bus_is_retried_counted_and_named():
    """EBUSY (another master holds the bus too long): retried with the same back-off, counted
    apart from NACKs (the run's link statistics), and named as such when it persists."""
    bus, emu, pauses = _bus(i2c_busy_at=0, i2c_fault_count=2)
    assert bus.read(0x0000) == 0xA2E5
    assert bus.link_counters() == {"transactions": 3, "nack_retries": 0, "busy_retries": 2, "timeout_retries": 0}
    bus, emu, pauses = _bus(i2c_busy_at=0, i2c_fault_count=10)
    with pytest.raises(DeviceGone, match=r"register 0x0010: bus busy on write after 4 attempt\(s\)"):
        bus.write(0x0010, 5)
    assert pauses == [BACKOFF_S, 2 * BACKOFF_S, 4 * BACKOFF_S] and bus.link_counters()["busy_retries"] == 3
