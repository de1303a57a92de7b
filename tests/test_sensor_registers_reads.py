"""Multi-register values read whole (issue 49's second item left undone). A 32-bit exposure in two
16-bit registers is read as two I2C transactions; on a free-running sensor a frame boundary -- where
a held change latches -- can fall between them, and the host reads the old high half with the new
low half. The emulated sensor (``SensorRegisters``: a frame boundary every ``frame_period_s`` of the
bench's clock, each I2C transaction taking its bus time) behaves so; one that latches the value
when one register is read (``read_latch``) copies the others at that read.

The truth is the device's: every value the host reads must be one the sensor held (the old or the
new exposure), never a mixture."""

from __future__ import annotations

import pytest

from ares.errors import HardwareError
from ares.hardware.emulators.i2c_device import EmulatedSMBus
from ares.hardware.emulators.sensor_registers import SensorRegisters
from ares.hardware.i2c import I2CRegisterBus
from ares.hardware.registers import Field, RegisterFile, RegisterMap
from ares.sim.bench import SimRegisterBus
from ares.sim.strict import SimClock

A, B = 0x0001_FFFF, 0x0002_0000  # every bit of both halves changes between them
EXPOSURE = Field("exposure", 0x0010, 0, 31, count=2)


def _sensor(latch=None, declared=None, period=700e-6, endian="big"):
    m = RegisterMap(16, 16, endian, (EXPOSURE,), group_hold=(0x0104, 1, 0), read_latch=declared)
    clock = SimClock()
    dev = SensorRegisters(m, SimRegisterBus(m), clock=clock, frame_period_s=period, read_latch=latch)
    bus = I2CRegisterBus(1, 0x36, 16, 16, smbus=EmulatedSMBus(0x36, dev, clock=clock))
    return RegisterFile(m, bus), dev


def _reads(regs, naive: bool, n: int = 60) -> list[int]:
    """``n`` times: the exposure changed (held: it latches at the next frame start), then read."""
    out = []
    lo, hi = regs._addresses(EXPOSURE)[::-1][0], regs._addresses(EXPOSURE)[0]
    for k in range(n):
        regs.set_raw("exposure", A if k % 2 else B)
        for _ in range(3):
            out.append(regs.bus.read(hi) << 16 | regs.bus.read(lo) if naive else regs.get_raw("exposure"))
    return out


def test_the_free_running_sensor_tears_a_read_and_the_host_reads_it_whole():
    regs, dev = _sensor()
    torn = set(_reads(regs, naive=True)) - {0, A, B}
    assert torn <= {A & 0xFFFF_0000 | B & 0xFFFF, B & 0xFFFF_0000 | A & 0xFFFF} and torn, torn  # the device tears
    regs, dev = _sensor()
    got = _reads(regs, naive=False)
    assert set(got) <= {0, A, B} and {A, B} <= set(got), set(got) - {0, A, B}
    assert len(dev.exposed) > 50  # (frame boundaries fell all through the reads)


@pytest.mark.parametrize("latch,endian", [("msb", "big"), ("lsb", "big"), ("msb", "little")])
def test_a_device_that_latches_on_one_register_is_read_once_that_register_first(latch, endian):
    """Declared, the value is read in one pass (two transactions) starting at the latching
    register; a device that latches on the other register would tear it (the declaration matters)."""
    regs, dev = _sensor(latch=latch, declared=latch, endian=endian)
    before = regs.bus.transactions
    assert regs.get_raw("exposure") == 0 and regs.bus.transactions - before == 2
    got = _reads(regs, naive=False)
    assert set(got) <= {0, A, B} and {A, B} <= set(got)
    other = {"msb": "lsb", "lsb": "msb"}[latch]
    regs, dev = _sensor(latch=other, declared=latch, endian=endian)
    assert set(_reads(regs, naive=False)) - {0, A, B}


def test_a_value_that_never_holds_still_is_one_sentence():
    """A value that changes during every read (a frame boundary between every two transactions)
    cannot be read whole: one sentence naming the device, the registers and the field."""
    regs, dev = _sensor(period=100e-6)
    regs.set_raw("exposure", A)
    dev.pending = {}  # (a sensor that latches a new exposure at every frame: the test drives it)
    orig = dev.frame_boundary

    def boundary():
        dev.pending = {0x10: dev.inner.read(0x10) ^ 3, 0x11: dev.inner.read(0x11) ^ 0xFFFF}
        orig()

    dev.frame_boundary = boundary
    with pytest.raises(HardwareError, match=r"i2c: the 2 registers from 0x10 changed during each of 4 reads: the "
                                            r"value cannot be read whole .*read_latch.* \(field 'exposure'\)"):
        regs.get_raw("exposure")


def test_read_latch_from_the_register_map_xml(tmp_path):
    """``<registers read_latch="msb">`` round-trips, reaches the wire bench's emulated sensor (the
    exposure read in one pass), and a value it does not take is one sentence with file and line.
    sim_wire verifies its writes: the low register's read-back reads the latching one first (read
    alone it answered the latch of an earlier read -- a false write-verify error)."""
    from ares.errors import InputError
    from ares.protocol import load_system, save_system
    from ares.rig.factory import build_bench
    from wire_small import small_wire

    p = small_wire(tmp_path, hold=False)  # (a held write would latch at the next frame only)
    regs_el = '<registers address_bits="16" value_bits="16" endian="big"'
    p.write_text(p.read_text().replace(regs_el, regs_el + ' read_latch="msb"'))
    sy = load_system(p)
    assert sy.registers.read_latch == "msb"
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").registers == sy.registers
    bench = build_bench(sy, seed=1)
    try:
        bench.registers.set("exposure", 0.004)
        before = bench.registers.bus.transactions
        assert bench.registers.get("exposure") == pytest.approx(0.004) and bench.registers.bus.transactions - before == 2
        assert bench.emulators["sensor_registers"].latch_on == {0x10: [0x11]}
    finally:
        bench.close()
    p.write_text(p.read_text().replace('read_latch="msb"', 'read_latch="middle"'))
    with pytest.raises(InputError, match=r"sim_wire_48x64\.xml:\d+: .*read_latch"):
        load_system(p)
