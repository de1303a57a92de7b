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
Every wait (light settle, chamber settle and soak) is bounded by the XML's timeouts and
cut short within 0.1 s by the run's stop/abort request (``ares.hardware.waits``).
"""

from __future__ import annotations

import math
import time

from ares.errors import DeviceGone, HardwareError, ValueOutOfRange
from ares.hardware.waits import wait


def range_text(lo: float | None, hi: float | None, unit: str) -> str:
    """``-20 .. 85 C``, ``>= 0 C`` or ``<= 85 C`` (a bound the XML does not give is open)."""
    if lo is not None and hi is not None:
        return f"{lo:g} .. {hi:g} {unit}".rstrip()
    return (f">= {lo:g} {unit}" if lo is not None else f"<= {hi:g} {unit}").rstrip()


class SerialInstrument:
    def __init__(self, port, cfg, *, sleep=time.sleep, clock=time.monotonic):
        self.port, self.cfg, self._sleep, self._clock = port, cfg, sleep, clock
        self.name = cfg.name

    def _wait(self, seconds: float, cancel=None) -> None:
        wait(seconds, cancel, sleep=self._sleep, clock=self._clock)

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
            raise ValueOutOfRange(f"{self.name}: {what} {value:g} {unit} is outside {range_text(lo, hi, unit)}")
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

    def settle(self, cancel=None) -> None:
        self._wait(self.cfg.settle_s, cancel)


class SerialChamber(SerialInstrument):
    _setpoint: float | None = None

    def set_temperature(self, celsius: float) -> None:
        v = self._check(celsius, "temperature", "C")
        if self.query(f"TEMP {v:.2f}") != "OK":
            raise HardwareError(f"{self.name} on {self.cfg.port}: unexpected reply to 'TEMP {v:.2f}'")
        self._setpoint = v

    def get_temperature(self) -> float:
        return self._number("TEMP?")

    def _at_setpoint(self) -> tuple[bool, str]:
        tol = self.cfg.tolerance
        if tol is None or self._setpoint is None:
            return self.query("STABLE?") == "1", "it never reported stable"
        t = self.get_temperature()
        return abs(t - self._setpoint) <= tol, (f"last reading {t:g} C, set point {self._setpoint:g} "
                                                f"+/- {tol:g} C")

    def settle(self, cancel=None) -> None:
        """Wait until the chamber is at its set point (within ``tolerance`` C of it when the
        XML gives one, else until it answers ``STABLE?`` with 1) continuously for ``hold_s``,
        polling every ``poll_s``; then soak ``settle_s``. Gives up after ``settle_timeout_s``."""
        cfg = self.cfg
        t0, held = self._clock(), None
        while True:
            ok, why = self._at_setpoint()
            now = self._clock()
            held = (held if held is not None else now) if ok else None
            if held is not None and now - held >= cfg.hold_s:
                break
            if now - t0 >= cfg.settle_timeout_s:
                raise HardwareError(f"{self.name} on {cfg.port}: not settled after {cfg.settle_timeout_s:g} s "
                                    f"(settle_timeout_s in the system XML; {why})")
            self._wait(cfg.poll_s, cancel)
        self._wait(cfg.settle_s, cancel)
