"""The I2C busy window declared in the system XML (issue 49): ``<i2c backoff_ms>`` is the
first pause before a retry after a NACK or a busy bus (doubled each attempt), no longer a
hard-coded 1 ms; it survives a save and reload."""

from __future__ import annotations

import errno

from ares.hardware.i2c import open_i2c_bus
from ares.protocol import load_system, save_system
from wire_small import small_wire


class _NackTwice:
    def __init__(self):
        self.calls = 0

    def i2c_rdwr(self, *msgs):
        self.calls += 1
        if self.calls <= 2:
            raise OSError(errno.ENXIO, "No such device or address")


def test_backoff_ms_is_the_first_pause_and_doubles(tmp_path):
    p = small_wire(tmp_path)
    p.write_text(p.read_text().replace('retries="2"', 'retries="2" backoff_ms="5"', 1))
    sy = load_system(p)
    assert sy.buses[0].backoff_ms == 5
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").buses[0].backoff_ms == 5
    bus = open_i2c_bus(sy.buses[0], sy.registers, _NackTwice())
    slept = []
    bus._sleep = slept.append
    bus.write(0x0010, 1, verify=False)
    assert slept == [0.005, 0.010] and bus.nack_retries == 2
