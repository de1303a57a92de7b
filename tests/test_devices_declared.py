"""Devices as the system XML declares them: I2C widths and byte orders, a serial instrument in
its own dialect (an XML entry, no code), the chamber's settling, and a GenICam camera
through the genicam wheel's simulated GenTL producer."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from ares.errors import DeviceGone, HardwareError, InputError
from ares.hardware.emulators.i2c_device import EmulatedSMBus
from ares.hardware.i2c import I2CRegisterBus
from ares.hardware.registers import Field, RegisterFile, RegisterMap
from ares.hardware.serial_instruments import SerialChamber, SerialLightSource
from ares.protocol import load_system

ROOT = Path(__file__).resolve().parents[1]


class Regs:
    """A plain register array behind the emulated I2C device."""

    def __init__(self, bits):
        self.v, self.bits = {}, bits

    def read(self, a):
        return self.v.get(a, 0)

    def write(self, a, value):
        assert 0 <= value < (1 << self.bits)
        self.v[a] = value


@pytest.mark.parametrize("abits", [8, 16])
@pytest.mark.parametrize("vbits", [8, 16, 32])
@pytest.mark.parametrize("endian", ["big", "little"])
def test_i2c_widths_and_byte_order_on_the_wire(abits, vbits, endian):
    regs = Regs(vbits)
    sm = EmulatedSMBus(0x10, regs, address_bits=abits, value_bits=vbits, value_endian=endian)
    bus = I2CRegisterBus(0, 0x10, abits, vbits, smbus=sm, value_endian=endian, verify=True)
    rmap = RegisterMap(abits, vbits, "big", (Field("wide", 0x20, 0, 2 * vbits - 1, count=2),
                                             Field("nib", 0x30, 4, 7)))
    rf = RegisterFile(rmap, bus)
    value = (1 << (2 * vbits)) - 3  # spans two registers, most significant first
    rf.set_raw("wide", value)
    assert regs.v[0x20] == value >> vbits and regs.v[0x21] == value & ((1 << vbits) - 1)
    assert rf.get_raw("wide") == value
    regs.v[0x30] = 0x0F
    rf.set_raw("nib", 0xA)  # read-modify-write keeps bits 0..3
    assert regs.v[0x30] == 0xAF
    # the bytes as smbus2 sent them: address big-endian, value in the declared order
    seen = []
    orig = sm.i2c_rdwr
    sm.i2c_rdwr = lambda *m: (seen.append(bytes(m[0])), orig(*m))[1]
    bus.write(0x0005, 0x01 if vbits == 8 else 0x0102)
    want_val = (0x01 if vbits == 8 else 0x0102).to_bytes(vbits // 8, endian)
    assert seen[0] == (5).to_bytes(abits // 8, "big") + want_val


def test_i2c_retries_then_one_sentence_and_write_verify():
    regs = Regs(16)
    sm = EmulatedSMBus(0x10, regs, faults={"i2c_nack_at": 0, "i2c_fault_count": 2})
    bus = I2CRegisterBus(4, 0x10, 16, 16, name="cam", smbus=sm, retries=2)
    bus.write(0x40, 7)  # two NACKs, the third attempt goes through
    assert regs.v[0x40] == 7 and bus.retried == 1
    sm = EmulatedSMBus(0x10, regs, faults={"i2c_nack_at": 0, "i2c_fault_count": 3})
    rf = RegisterFile(RegisterMap(16, 16, "big", (Field("gain", 0x40, 0, 15),)),
                      I2CRegisterBus(4, 0x10, 16, 16, name="cam", smbus=sm, retries=2))
    with pytest.raises(DeviceGone, match=r"^I2C device 0x10 on bus 4 \('cam'\), register 0x0040: no acknowledge on "
                                         r"write after 3 attempt\(s\) \(.*\) \(field 'gain'\)$"):
        rf.set_raw("gain", 5)

    class Sticky(Regs):  # a register that ignores writes
        def write(self, a, value):
            pass

    bus = I2CRegisterBus(4, 0x10, 16, 16, name="cam", smbus=EmulatedSMBus(0x10, Sticky(16)), verify=True)
    with pytest.raises(HardwareError, match=r"register 0x0040: wrote 0x5 but read back 0x0 \(write-verify\)"):
        bus.write(0x40, 5)
    wrong = I2CRegisterBus(4, 0x11, 16, 16, name="cam", smbus=EmulatedSMBus(0x10, Regs(16)), retries=0)
    with pytest.raises(DeviceGone, match="I2C device 0x11 on bus 4 .* no acknowledge"):
        wrong.read(0)


class ScriptedPort:
    """A serial port answering in a vendor's dialect: 'L=<x>\\r' -> 'ACK\\r', 'L?\\r' -> 'L=<x>\\r'."""

    def __init__(self):
        self.level, self.rx, self.written = 0.0, b"", []

    def write(self, data):
        self.written.append(data)
        cmd = data.decode().rstrip("\r")
        if cmd.startswith("L="):
            self.level = float(cmd[2:])
            self.rx += b"ACK\r" if self.level <= 100 else b"NAK overrange\r"
        elif cmd == "L?":
            self.rx += f"L={self.level:.1f}\r".encode()

    def read_until(self, term):
        i = self.rx.find(term)
        out, self.rx = (self.rx, b"") if i < 0 else (self.rx[:i + 1], self.rx[i + 1:])
        return out

    def close(self):
        pass


def test_a_new_instrument_is_an_xml_entry(tmp_path):
    xml = (ROOT / "protocols" / "black_widow.xml").read_text().replace(
        """<light_source name="led" port="/dev/ttyUSB0" baud="9600" parity="N" stopbits="1" bytesize="8" timeout_s="1"
                  min="0" max="10000000" unit="photons/pixel/s" settle_s="0.2"/>""",
        """<light_source name="lamp" port="/dev/ttyS3" baud="9600" timeout_s="1" min="0" max="1000" unit="%">
      <protocol terminator="\\r" reply_terminator="\\r" error="NAK\\s*(?P&lt;text&gt;.*)">
        <command name="set" send="L={value:.1f}" reply="ACK"/>
        <command name="get" send="L?" reply="L=(?P&lt;value&gt;[0-9.]+)"/>
      </protocol>
    </light_source>""")
    p = tmp_path / "bw_lamp.xml"
    p.write_text(xml)
    sy = load_system(p)
    assert sy.light_source.protocol.terminator == "\r"
    port = ScriptedPort()
    lamp = SerialLightSource(port, sy.light_source, sleep=lambda s: None)
    lamp.set_level(42.25)
    assert port.written[-1] == b"L=42.2\r" and lamp.get_level() == pytest.approx(42.2)
    with pytest.raises(HardwareError, match=r"lamp on /dev/ttyS3: refused 'L=500.0': overrange"):
        lamp.set_level(500)
    from ares.protocol.system import save_system

    save_system(sy, tmp_path / "again.xml")  # the dialect survives a save (run directories copy it)
    assert load_system(tmp_path / "again.xml").light_source.protocol == sy.light_source.protocol
    bad = xml.replace('<command name="get" send="L?" reply="L=(?P&lt;value&gt;[0-9.]+)"/>', "")
    p.write_text(bad)
    with pytest.raises(InputError, match=r"bw_lamp.xml:\d+: <light_source> <protocol> declares no command named 'get'"):
        load_system(p)


def test_chamber_settles_within_tolerance_for_hold_time_over_the_emulator():
    """The emulated chamber drifts to its set point; settle() waits until it is within the
    tolerance for hold_s, on a fake clock (no wall-clock time)."""
    import serial

    from ares.hardware.emulators.serial_device import EmulatedChamber, register, unregister
    from ares.sim.bench import SimChamber

    class Drifting(SimChamber):  # 1 C per poll towards the set point
        def __init__(self):
            super().__init__()
            self.target = 25.0

        def set_temperature(self, c):
            self.target = float(c)

        def get_temperature(self):
            self._t += max(-1.0, min(1.0, self.target - self._t))
            return self._t

    cfg = dataclasses.replace(load_system(ROOT / "protocols" / "sim_wire.xml").chamber, tolerance=0.5, hold_s=3,
                              poll_s=1, settle_s=0, settle_timeout_s=30)
    emu = EmulatedChamber(Drifting())
    register("chamber", emu)
    try:
        t = [0.0]
        ch = SerialChamber.open(cfg, sleep=lambda s: t.__setitem__(0, t[0] + s), clock=lambda: t[0])
        ch.set_temperature(30)
        ch.settle()
        assert ch.get_temperature() == 30 and t[0] == pytest.approx(7.0)  # at 30 C after 4 s, then held 3 s
        ch.set_temperature(100)  # 70 C away at 1 C/s: the timeout ends the wait, naming the chamber
        with pytest.raises(HardwareError, match=r"chamber on aresemu://chamber: not settled after 30 s"):
            ch.settle()
        ch.close()
    finally:
        unregister("chamber", emu)
    with pytest.raises(DeviceGone, match=r"chamber: cannot open serial port aresemu://chamber"):
        SerialChamber.open(cfg)
    assert "ares.hardware.emulators" in serial.protocol_handler_packages


def _genicam_missing() -> str | None:
    try:
        import genicam  # noqa: F401
        import harvesters  # noqa: F401
    except ImportError as exc:
        return f"the genicam wheel is not available for this Python/platform ({exc})"
    return None


@pytest.mark.skipif(_genicam_missing() is not None, reason=str(_genicam_missing()))
def test_genicam_scan_on_the_simulated_producer(tmp_path):
    from ares.cli import main

    out = tmp_path / "run"
    assert main(["run", str(ROOT / "scans" / "genicam_quick.xml"), "--out", str(out), "-q"]) == 0
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "done" and meta["stages_completed"] == 2
    st = json.loads((out / "stages" / "0001.json").read_text())
    assert st["registers_after"]["ball_size"] == 30 and st["registers_after"]["frame_rate"] == 100
    assert (out / "report.pdf").stat().st_size > 0


@pytest.mark.skipif(_genicam_missing() is not None, reason=str(_genicam_missing()))
def test_genicam_frames_features_and_errors():
    from ares.rig.factory import build_bench

    sy = load_system(ROOT / "protocols" / "genicam_sim.xml")
    b = build_bench(sy)
    try:
        b.registers.set("ball_size", 12)
        assert b.registers.get("ball_size") == 12
        frames = list(b.frames.grab(3))
        assert [f.data.shape for f in frames] == [(400, 400)] * 3 and frames[0].data.dtype == np.uint8
        ids = [f.meta["frame_id"] for f in frames]
        assert ids == list(range(ids[0], ids[0] + 3))
        with pytest.raises(Exception, match="ball_size.*above its maximum 40"):
            b.registers.set("ball_size", 41)
    finally:
        b.close()
    bad = dataclasses.replace(sy, genicam=dataclasses.replace(sy.genicam, device="no-such-cam"))
    with pytest.raises(DeviceGone, match=r"GenICam camera 'viky': no camera 'no-such-cam' \(the producer lists: "):
        build_bench(bad)
    gone = dataclasses.replace(sy, genicam=dataclasses.replace(sy.genicam, cti="/nonexistent/x.cti"))
    with pytest.raises(DeviceGone, match=r"GenICam camera 'viky': GenTL producer /nonexistent/x.cti does not exist"):
        build_bench(gone)
