"""Real backends at byte level: I2C transactions, USB frames, serial request/reply pairs."""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np
import pytest

from ares.errors import DeviceGone, FrameError, HardwareError, ValueOutOfRange
from ares.hardware.i2c import I2CRegisterBus
from ares.hardware.registers import RegisterFile
from ares.hardware.serial_instruments import SerialChamber, SerialLightSource
from ares.hardware.usb import UsbFrameSource
from ares.protocol import load_system

ROOT = Path(__file__).resolve().parents[1]
BW = load_system(ROOT / "protocols" / "black_widow.xml")


class FakeSMBus:
    """Records each i2c_rdwr transaction; a 16-bit-address, 8-bit-value register file."""

    def __init__(self, regs=None, fail=False):
        self.regs = dict(regs or {})
        self.log = []
        self.fail = fail

    def i2c_rdwr(self, *msgs):
        if self.fail:
            raise OSError(121, "Remote I/O error")
        w = bytes(msgs[0])
        self.log.append(tuple((m.addr, m.flags, bytes(m)) for m in msgs))
        reg = int.from_bytes(w[:2], "big")
        if len(msgs) == 1:  # write: address + value bytes
            for i, b in enumerate(w[2:]):
                self.regs[reg + i] = b
        else:
            r = msgs[1]
            data = bytes(self.regs.get(reg + i, 0) for i in range(r.len))
            ctypes.memmove(r.buf, data, r.len)

    def close(self):
        pass


def test_i2c_write_and_read_bytes():
    sm = FakeSMBus({0x0000: 0xB1, 0x0001: 0xD0})
    bus = I2CRegisterBus(1, 0x36, 16, 8, name="sensor", smbus=sm)
    bus.write(0x0010, 0x07)
    assert sm.log[-1] == ((0x36, 0, b"\x00\x10\x07"),)
    assert bus.read(0x0001) == 0xD0
    (w, r) = sm.log[-1]
    assert w == (0x36, 0, b"\x00\x01") and r[0] == 0x36 and r[1] == 1  # I2C_M_RD


def test_i2c_multi_register_exposure_through_register_file():
    sm = FakeSMBus()
    rf = RegisterFile(BW.registers, I2CRegisterBus(1, 0x36, 16, 8, smbus=sm))
    rf.set("exposure", 0.5)  # 25000 row periods of 20 us = 0x0061A8 over 0x10..0x12, big-endian
    assert [sm.regs[a] for a in (0x10, 0x11, 0x12)] == [0x00, 0x61, 0xA8]
    assert rf.get("exposure") == pytest.approx(0.5)
    rf.set("readback_mode", 1)  # partial field: read-modify-write keeps bit 0
    rf.set("streaming", 1)
    assert sm.regs[0x04] == 0b11


def test_i2c_errors_name_the_device():
    bus = I2CRegisterBus(3, 0x36, 16, 8, name="sensor", smbus=FakeSMBus(fail=True))
    with pytest.raises(DeviceGone, match=r"I2C device 0x36 on bus 3 \('sensor'\), register 0x0010: no acknowledge "
                                         r"on read after 3 attempt\(s\)"):
        bus.read(0x10)
    with pytest.raises(ValueOutOfRange, match="does not fit in 8 bits"):
        I2CRegisterBus(1, 0x36, 16, 8, smbus=FakeSMBus()).write(0x10, 256)


def test_i2c_missing_bus_is_device_gone():
    with pytest.raises(DeviceGone, match="cannot open /dev/i2c-97"):
        I2CRegisterBus(97, 0x36)


class FakeUsb:
    """pyusb's Device.read into the caller's buffer: each scripted item is one transfer."""

    def __init__(self, frames):
        self.frames = list(frames)
        self.reads = []

    def read(self, ep, buf, timeout=None):
        self.reads.append((ep, len(buf), timeout))
        item = self.frames.pop(0)
        if isinstance(item, Exception):
            raise item
        n = min(len(item), len(buf))
        buf[:n] = type(buf)("B", item[:n])
        if n < len(item):
            self.frames.insert(0, item[n:])
        return n


def test_usb_frames_decode_and_faults():
    import usb.core

    g = BW.usb_grabber
    shape = (BW.sensor.rows, BW.sensor.cols)
    img = (np.arange(shape[0] * shape[1]) % 2048).astype("<u2").reshape(shape)
    dev = FakeUsb([img.tobytes(), img.tobytes()[:100], img.tobytes()])
    src = UsbFrameSource(dev, g, shape, 11)
    it = src.grab(3)
    f0 = next(it)
    assert np.array_equal(f0.data, img) and f0.data.dtype == np.uint16
    assert dev.reads[0] == (0x82, -(-shape[0] * shape[1] * 2 // 512) * 512, 2000)  # whole 512-byte packets
    with pytest.raises(FrameError, match=r"frame 1 arrived short \(100 of 343440 bytes\)"):
        next(it)
    bad = img.copy()
    bad[0, 0] = 4000
    with pytest.raises(FrameError, match="corrupt"):
        next(UsbFrameSource(FakeUsb([bad.tobytes()]), g, shape, 11).grab(1))
    with pytest.raises(HardwareError, match=r"no data on endpoint 0x82 within 2000 ms \(timeout\)"):
        next(UsbFrameSource(FakeUsb([usb.core.USBTimeoutError("t")]), g, shape, 11).grab(1))
    with pytest.raises(DeviceGone, match="disconnected"):
        next(UsbFrameSource(FakeUsb([usb.core.USBError("No such device", errno=19)]), g, shape, 11).grab(1))


def test_usb_grabber_absent():
    class NoBackend:  # usb.core.find with a backend that enumerates nothing
        def enumerate_devices(self):
            return iter(())

    with pytest.raises(DeviceGone, match=r"'grabber' \(04b4:00f1\) is not connected"):
        UsbFrameSource.open(BW.usb_grabber, (405, 424), 11, backend=NoBackend())


class FakePort:
    """Scripted serial port: expected request -> reply pairs, in order."""

    def __init__(self, script):
        self.script = list(script)
        self.written = []
        self.pending = b""

    def write(self, data):
        self.written.append(data)
        want, reply = self.script.pop(0)
        assert data == want, (data, want)
        self.pending = reply

    def readline(self):
        r, self.pending = self.pending, b""
        return r

    def close(self):
        pass


def test_light_source_request_reply():
    port = FakePort([(b"LEVEL 250000\n", b"OK\n"), (b"LEVEL?\n", b"250000.0\n"), (b"*IDN?\n", b"ARES LED,1\r\n")])
    ls = SerialLightSource(port, BW.light_source, sleep=lambda s: None)
    ls.set_level(2.5e5)
    assert ls.get_level() == 2.5e5 and ls.identify() == "ARES LED,1"
    with pytest.raises(ValueOutOfRange, match="light level 2e\\+07 photons/pixel/s is outside 0 .. 1e\\+07"):
        ls.set_level(2e7)
    assert port.script == []


def test_light_source_errors():
    ls = SerialLightSource(FakePort([(b"LEVEL 5\n", b"ERR lamp failure\n")]), BW.light_source)
    with pytest.raises(HardwareError, match="led on /dev/ttyUSB0: refused 'LEVEL 5': lamp failure"):
        ls.set_level(5)
    ls = SerialLightSource(FakePort([(b"LEVEL?\n", b"")]), BW.light_source)
    with pytest.raises(HardwareError, match=r"no reply to 'LEVEL\?' within 1 s \(timeout") as e:
        ls.get_level()
    assert not isinstance(e.value, DeviceGone)  # silent, not unplugged
    ls = SerialLightSource(FakePort([(b"LEVEL?\n", b"bright\n")]), BW.light_source)
    with pytest.raises(HardwareError, match="is not a number"):
        ls.get_level()


class FakeClock:
    """Monotonic clock advanced by the instrument's own sleeps (no wall-clock time passes)."""

    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t

    def sleep(self, s):
        self.t += s


def test_chamber_set_and_settle():
    port = FakePort([(b"TEMP 40.00\n", b"OK\n"), (b"STABLE?\n", b"0\n"), (b"STABLE?\n", b"1\n"),
                     (b"TEMP?\n", b"39.98\n")])
    clock = FakeClock()
    ch = SerialChamber(port, BW.chamber, sleep=clock.sleep, clock=clock)
    ch.set_temperature(40)
    ch.settle()
    assert ch.get_temperature() == pytest.approx(39.98)
    assert clock.t == pytest.approx(61.0)  # one 1 s poll, then the 60 s soak from settle_s
    with pytest.raises(ValueOutOfRange, match="temperature 100 C is outside -20 .. 85 C"):
        ch.set_temperature(100)


def _chamber(replies, **cfg):
    """A chamber answering TEMP? with ``replies`` (then the last one forever)."""
    import dataclasses

    class Port(FakePort):
        def write(self, data):
            self.written.append(data)
            if data.startswith(b"TEMP?"):
                self.pending = (replies.pop(0) if len(replies) > 1 else replies[0]).encode() + b"\n"
            else:
                self.pending = b"OK\n"

    clock = FakeClock()
    c = dataclasses.replace(BW.chamber, **cfg)
    return SerialChamber(Port([]), c, sleep=clock.sleep, clock=clock), clock


def test_chamber_tolerance_and_hold_from_xml():
    # in band at 1-2 s, out at 3 s, back in from 4 s: settled once held 10 s (at 14 s), then the 5 s soak
    ch, clock = _chamber(["30", "39.5", "39.9", "41", "40.2"], tolerance=0.5, hold_s=10, poll_s=1, settle_s=5)
    ch.set_temperature(40)
    ch.settle()
    assert clock.t == pytest.approx(4 + 10 + 5)


def test_chamber_that_never_settles_times_out_with_the_reason():
    ch, clock = _chamber(["37"], tolerance=0.5, settle_timeout_s=600, poll_s=2)
    ch.set_temperature(40)
    with pytest.raises(HardwareError, match=r"chamber on /dev/ttyUSB1: not settled after 600 s .*"
                                            r"last reading 37 C, set point 40 \+/- 0.5 C"):
        ch.settle()
    assert clock.t == pytest.approx(600)


def test_chamber_wait_ends_within_a_slice_of_a_stop_request():
    from ares.hardware.waits import SLICE_S, Interrupted

    ch, clock = _chamber(["37"], tolerance=0.5, settle_timeout_s=7200, poll_s=30)
    ch.set_temperature(40)
    with pytest.raises(Interrupted):
        ch.settle(cancel=lambda: clock.t >= 100.0)  # the user presses Ctrl-C at t = 100 s
    assert 100.0 <= clock.t <= 100.0 + SLICE_S + 1e-9


def test_chamber_without_min_or_max_range_text():
    import dataclasses

    port = FakePort([])
    ch = SerialChamber(port, dataclasses.replace(BW.chamber, min=None), sleep=lambda s: None)
    with pytest.raises(ValueOutOfRange, match="temperature 100 C is outside <= 85 C"):
        ch.set_temperature(100)


def test_serial_port_missing():
    with pytest.raises(DeviceGone, match="led: cannot open serial port /dev/ttyUSB0"):
        SerialLightSource.open(BW.light_source.__class__(**{**BW.light_source.__dict__}))


def test_factory_real_bench_reports_missing_hardware():
    from ares.rig.factory import build_bench

    with pytest.raises(DeviceGone):  # no /dev/i2c-1 (or no device) on the test machine
        build_bench(BW)


def test_simulated_system_must_use_the_sim_register_map():
    import dataclasses

    from ares.errors import InputError
    from ares.rig.factory import build_bench
    from ares.protocol import Simulator

    odd = dataclasses.replace(BW, simulator=Simulator(1, {}))
    with pytest.raises(InputError, match="must declare the simulated sensor's register map"):
        build_bench(odd)
