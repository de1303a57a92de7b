"""I2C at connect (issue 36, finding 6): bus number and speed from the XML, a chip-ID check,
the <init> sequence, volatile registers -- on the real smbus2 code (SMBus, i2c_msg, the
ioctl data) with only the kernel calls replaced (``KernelI2C``: os.open of /dev/i2c-N and
ioctl)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from ares.errors import HardwareError
from ares.hardware.emulators.i2c_device import EmulatedSMBus, KernelI2C
from ares.hardware.i2c import I2CRegisterBus, open_i2c_bus
from ares.protocol import load_system, save_system

WIRE = Path(__file__).resolve().parents[1] / "protocols" / "sim_wire.xml"


class Chip:
    """Registers with a chip ID at 0x0000; 0x0103 is a self-clearing software reset."""

    def __init__(self, chip_id):
        self.v, self.log = {0x0000: chip_id}, []

    def read(self, a):
        return self.v.get(a, 0)

    def write(self, a, value):
        self.log.append((a, value))
        self.v[a] = 0 if a == 0x0103 else value  # the reset clears itself


def _kernel(**chips):
    """{bus number: Chip} behind /dev/i2c-N, device address 0x36, 16-bit addresses and values."""
    return KernelI2C({int(k[3:]): EmulatedSMBus(0x36, c, address_bits=16, value_bits=16) for k, c in chips.items()})


def _bus(number, pauses=None, **kw):
    return I2CRegisterBus(number, 0x36, 16, 16, name="sensor", sleep=(pauses if pauses is not None else []).append,
                          sysfs="/nonexistent", **kw)


def test_the_declared_bus_number_is_opened_and_the_chip_id_checked():
    kernel = _kernel(bus1=Chip(0x1234), bus3=Chip(0xA2E5))
    with kernel.installed():
        bus = _bus(3, chip_id=(0x0000, 0xA2E5))
        bus.connect()
        assert kernel.opened == ["/dev/i2c-3"] and bus.read(0x0000) == 0xA2E5
        wrong = _bus(1, chip_id=(0x0000, 0xA2E5))
        with pytest.raises(HardwareError, match=r"^I2C device 0x36 on bus 1 \('sensor'\), register 0x0000: chip ID "
                                                r"reads 0x1234 but the system XML expects 0xa2e5"):
            wrong.connect()
        with pytest.raises(Exception, match="cannot open /dev/i2c-2"):
            _bus(2)


def test_init_sequence_runs_in_order_after_the_chip_id_and_again_after_a_reconnect():
    chip = Chip(0xA2E5)
    kernel, pauses = _kernel(bus1=chip), []
    init = (("write", 0x0103, 1), ("wait", 0.005, 0), ("write", 0x3000, 0x00FF), ("write", 0x3002, 0x0001))
    with kernel.installed():
        bus = _bus(1, pauses, chip_id=(0x0000, 0xA2E5), init=init, verify=True)
        bus.connect()  # the reset clears itself: init writes are not read back
        assert chip.log == [(0x0103, 1), (0x3000, 0xFF), (0x3002, 1)] and pauses == [0.005]
        bus.reconnect()
        assert chip.log[3:] == chip.log[:3] and pauses == [0.005, 0.005]


def test_a_volatile_register_is_not_verified_by_read_back():
    chip = Chip(0xA2E5)
    with _kernel(bus1=chip).installed():
        with pytest.raises(HardwareError, match=r"register 0x0103: wrote 0x1 but read back 0x0 \(write-verify\)"):
            _bus(1, verify=True).write(0x0103, 1)
        bus = _bus(1, verify=True, volatile={0x0103})
        bus.write(0x0103, 1)
        bus.write(0x3000, 7)  # the others still verified (and pass)
        assert chip.log[-2:] == [(0x0103, 1), (0x3000, 7)]


@pytest.mark.parametrize("adapter_hz,ok", [(100000, True), (400000, True), (1000000, False)])
def test_the_adapter_clock_must_not_exceed_the_declared_speed(tmp_path, adapter_hz, ok):
    node = tmp_path / "i2c-1" / "of_node"
    node.mkdir(parents=True)
    (node / "clock-frequency").write_bytes(adapter_hz.to_bytes(4, "big"))  # device tree: big-endian u32
    with _kernel(bus1=Chip(0xA2E5)).installed():
        bus = I2CRegisterBus(1, 0x36, 16, 16, name="sensor", speed_hz=400000, sysfs=str(tmp_path))
        if ok:
            bus.connect()
            assert bus.adapter_hz == adapter_hz
        else:
            with pytest.raises(HardwareError, match=r"bus 1 \('sensor'\) runs at 1000000 Hz .* declares "
                                                    r"speed_hz=400000"):
                bus.connect()


def test_chip_id_init_and_volatile_from_the_system_xml_round_trip(tmp_path):
    text = WIRE.read_text().replace('speed_hz="400000"', 'speed_hz="100000"').replace(
        '<wait ms="1"/>', '<wait ms="2"/>').replace(
        'name="test_mode" address="0x0030"', 'name="test_mode" volatile="true" address="0x0030"')
    p = tmp_path / "sys.xml"
    p.write_text(text)
    sy = load_system(p)
    b = sy.buses[0]
    assert b.chip_id == (0, 0xA2E5) and b.init == (("write", 1, 1), ("wait", 0.002, 0)) and b.speed_hz == 100000
    assert sy.registers.field("test_mode").volatile
    save_system(sy, tmp_path / "again.xml")
    again = load_system(tmp_path / "again.xml")
    assert again.buses == sy.buses and again.registers == sy.registers
    bus = open_i2c_bus(b, sy.registers, EmulatedSMBus(0x36, Chip(0xBEEF), address_bits=16, value_bits=16))
    assert bus.volatile == {0x0030} and bus.speed_hz == 100000
    with pytest.raises(HardwareError, match="chip ID reads 0xbeef but the system XML expects 0xa2e5"):
        bus.connect()
