"""Serial on a real pty (issue 36, finding 7): an instrument that echoes each command, line
noise answered by a bounded retry, and a silent instrument (timeout) told apart from an
unplugged one (the pty's other side closed). The host is pyserial on the pty's slave; the
instrument is a thread on the master."""

from __future__ import annotations

import dataclasses
import os
import threading
from pathlib import Path

import pytest

from ares.errors import DeviceGone, HardwareError
from ares.hardware.serial_instruments import SerialLightSource
from ares.protocol import load_system

ROOT = Path(__file__).resolve().parents[1]


class PtyInstrument:
    """A light source on the master side of a pty: ``LEVEL x`` -> ``OK``, ``LEVEL?`` -> x.
    ``echo``: each command line comes back first. ``script``: per received command, what to
    do instead of answering -- "noise" (bytes of line noise), "silent" (nothing), "unplug"
    (close the master: the port is gone)."""

    def __init__(self, echo=False, script=None):
        self.master, self.slave = os.openpty()  # the slave stays open: with none, the master reads EIO
        self.path = os.ttyname(self.slave)
        self.echo, self.script, self.level, self.received = echo, dict(script or {}), 0.0, []
        self.closed = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def close(self):
        """End the instrument: with its slave closed too, the master reads EIO and the thread ends."""
        os.close(self.slave)
        if not self.closed.is_set():
            os.close(self.master)
        self.thread.join(timeout=10)

    def _serve(self):
        buf = b""
        while True:
            try:
                chunk = os.read(self.master, 256)
            except OSError:  # the host closed its side
                break
            buf += chunk
            while b"\n" in buf:
                line, buf = buf.split(b"\n", 1)
                cmd = line.decode().strip()
                n = len(self.received)
                self.received.append(cmd)
                action = self.script.get(n)
                if action == "unplug":
                    self.closed.set()
                    os.close(self.master)
                    return
                if action == "silent":
                    continue
                out = (cmd + "\r\n").encode() if self.echo else b""
                if action == "noise":
                    out += b"\x9f\xe2O\x00K\n"
                elif cmd.startswith("LEVEL?"):
                    out += f"{self.level!r}\n".encode()
                elif cmd.startswith("LEVEL "):
                    self.level = float(cmd.split()[1])
                    out += b"OK\n"
                else:
                    out += b"ARES,pty-led,1\n"
                os.write(self.master, out)


def _led(dev, echo=False, retries=0, timeout_s=120.0):  # (every reply here ends its line: none waits this out)
    cfg = load_system(ROOT / "protocols" / "sim_wire.xml").light_source
    proto = dataclasses.replace(cfg.protocol, echo=echo, retries=retries)
    return SerialLightSource.open(dataclasses.replace(cfg, port=dev.path, timeout_s=timeout_s, protocol=proto))


def test_an_echoing_instrument_is_understood_when_declared():
    dev = PtyInstrument(echo=True)
    led = _led(dev, echo=True)
    try:
        led.set_level(1234.5)
        assert led.get_level() == 1234.5
        # undeclared, the echo is taken for the reply: '*IDN?' is no identity (issue 54), so the
        # instrument is refused at open rather than recorded as '*IDN?'
        with pytest.raises(HardwareError, match=r"reply '\*IDN\?' to '\*IDN\?' does not match"):
            _led(dev, echo=False)
    finally:
        led.close()
        dev.close()


def test_line_noise_is_retried_within_the_bound():
    dev = PtyInstrument(script={1: "noise", 3: "noise", 4: "noise"})  # (command 0: *IDN? at open)
    led = _led(dev, retries=1)
    try:
        assert led.identity()["idn"] == "ARES,pty-led,1"
        led.set_level(7.0)  # garbled once, answered on the retry
        assert led.retried == 1 and dev.received[:3] == ["*IDN?", "LEVEL 7.0", "LEVEL 7.0"]
        with pytest.raises(HardwareError, match=r"reply .* to 'LEVEL\?' holds bytes that are not printable ASCII "
                                                r"\(garbled\) after 2 attempts"):
            led.get_level()  # garbled twice: the bound
        assert len(dev.received) == 5
        assert led.link_counters() == {"commands": 5, "retries": 2, "garbled": 3, "timeouts": 0}
    finally:
        led.close()
        dev.close()


def test_a_silent_instrument_is_a_timeout_not_an_unplugged_port():
    dev = PtyInstrument(script={1: "silent", 3: "unplug"})  # (command 0: *IDN? at open)
    led = _led(dev, timeout_s=0.2)
    try:
        with pytest.raises(HardwareError, match=r"no reply to 'LEVEL 1.0' within 0.2 s \(timeout: the instrument "
                                                r"is silent") as e:
            led.set_level(1.0)
        assert not isinstance(e.value, DeviceGone) and led.link_counters()["timeouts"] == 1
        # minutes from here: a loaded machine may answer late, and the unplug must be seen as
        # such (EIO at once), not as another timeout
        led.port.timeout = 120.0
        led.set_level(2.0)  # still there
        with pytest.raises(DeviceGone, match=r"led on /dev/pts/\d+: port error on 'LEVEL 3.0'") as e:
            led.set_level(3.0)
        assert e.value.device == "light" and dev.closed.is_set()
    finally:
        led.close()
        dev.close()
