"""Light source and thermal chamber over a serial port (pyserial).

Line protocol (ASCII, ``\\n``-terminated, one reply line per command)::

    *IDN?          -> identification
    LEVEL <x>      -> OK           (light source; x in the unit the system XML declares)
    LEVEL?         -> <x>
    TEMP <c>       -> OK           (chamber; degrees C)
    TEMP?          -> <c>
    STABLE?        -> 1 | 0        (chamber at set point)
    errors         -> ERR <text>

Values are range-checked against the XML's min/max before anything is sent. A missing
reply (timeout) is ``DeviceGone``; an ``ERR`` reply is a ``HardwareError`` quoting it.
"""

from __future__ import annotations

import math
import time

from ares.errors import DeviceGone, HardwareError, ValueOutOfRange


class SerialInstrument:
    def __init__(self, port, cfg, *, sleep=time.sleep):
        self.port, self.cfg, self._sleep = port, cfg, sleep
        self.name = cfg.name

    @classmethod
    def open(cls, cfg, **kw):
        import serial

        try:
            port = serial.Serial(cfg.port, baudrate=cfg.baud, bytesize=cfg.bytesize, parity=cfg.parity,
                                 stopbits=cfg.stopbits, timeout=cfg.timeout_s)
        except (serial.SerialException, OSError) as exc:
            raise DeviceGone(f"{cfg.name}: cannot open serial port {cfg.port} ({exc})") from None
        return cls(port, cfg, **kw)

    def query(self, command: str) -> str:
        try:
            self.port.write((command + "\n").encode("ascii"))
            line = self.port.readline()
        except OSError as exc:
            raise DeviceGone(f"{self.name} on {self.cfg.port}: port error on '{command}' ({exc})") from None
        if not line.endswith(b"\n"):
            raise DeviceGone(f"{self.name} on {self.cfg.port}: no reply to '{command}' within {self.cfg.timeout_s:g} s")
        reply = line.decode("ascii", "replace").strip()
        if reply.startswith("ERR"):
            raise HardwareError(f"{self.name} on {self.cfg.port}: refused '{command}': {reply[3:].strip()}")
        return reply

    def _number(self, command: str) -> float:
        reply = self.query(command)
        try:
            return float(reply)
        except ValueError:
            raise HardwareError(f"{self.name} on {self.cfg.port}: reply '{reply}' to '{command}' is not a number") from None

    def _check(self, value: float, what: str, unit: str) -> float:
        value = float(value)
        lo, hi = self.cfg.min, self.cfg.max
        if not math.isfinite(value) or (lo is not None and value < lo) or (hi is not None and value > hi):
            raise ValueOutOfRange(f"{self.name}: {what} {value:g} {unit} is outside {lo:g} .. {hi:g} {unit}")
        return value

    def identify(self) -> str:
        return self.query("*IDN?")

    def close(self) -> None:
        self.port.close()


class SerialLightSource(SerialInstrument):
    def set_level(self, level: float) -> None:
        v = self._check(level, "light level", self.cfg.unit or "")
        if self.query(f"LEVEL {v:.6g}") != "OK":
            raise HardwareError(f"{self.name} on {self.cfg.port}: unexpected reply to 'LEVEL {v:.6g}'")

    def get_level(self) -> float:
        return self._number("LEVEL?")

    def settle(self) -> None:
        self._sleep(self.cfg.settle_s)


class SerialChamber(SerialInstrument):
    max_wait_s = 7200.0
    poll_s = 1.0

    def set_temperature(self, celsius: float) -> None:
        v = self._check(celsius, "temperature", "C")
        if self.query(f"TEMP {v:.2f}") != "OK":
            raise HardwareError(f"{self.name} on {self.cfg.port}: unexpected reply to 'TEMP {v:.2f}'")

    def get_temperature(self) -> float:
        return self._number("TEMP?")

    def settle(self) -> None:
        """Wait until the chamber reports stable, then soak ``settle_s``."""
        waited = 0.0
        while self.query("STABLE?") != "1":
            if waited >= self.max_wait_s:
                raise HardwareError(f"{self.name}: not stable after {self.max_wait_s:g} s")
            self._sleep(self.poll_s)
            waited += self.poll_s
        self._sleep(self.cfg.settle_s)
