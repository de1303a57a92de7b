"""Light source and thermal chamber over a serial port (pyserial), in the line protocol the
system XML declares (``<protocol>``: commands with a ``send`` template and a ``reply``
pattern, terminators, the error pattern), so a new instrument is an XML entry, not code.
Without ``<protocol>`` the built-in dialect (``ares.hardware.line_protocol.DEFAULT_LIGHT`` /
``DEFAULT_CHAMBER``)::

    *IDN?          -> identification
    LEVEL <x>      -> OK           (light source; x in the unit the system XML declares)
    LEVEL?         -> <x>
    TEMP <c>       -> OK           (chamber; degrees C)
    TEMP?          -> <c>
    STABLE?        -> 1 | 0        (chamber at set point)
    errors         -> ERR <text>

The port may be a device (``/dev/ttyUSB0``) or any pyserial URL (``socket://``,
``rfc2217://``, ``loop://``, and ``aresemu://NAME`` for ARES's instrument emulators).
Values are range-checked against the XML's min/max before anything is sent. The input
buffer is flushed before every command, so a reply that came after its command timed out
cannot answer the next one. ``<protocol echo="true">``: the instrument sends the command
line back first; it must come back unchanged. A garbled reply (bytes that are not printable
ASCII, a bad echo, a reply the command's pattern does not match) or none at all is tried
again ``retries`` times (``<protocol retries>``, default 0); a reply matching the error
pattern is the instrument refusing (``HardwareError`` quoting it, never retried).
Instruments that talk unprompted: lines matching a declared ``<ignore pattern>`` (status
lines, asynchronous notices) are skipped wherever they come, and lines matching the
``<stream pattern>`` (a meter's streamed readings) are never taken as a reply, except by a
command declared ``stream="true"`` (its reply is the next streamed reading). A command's own
``timeout_s`` and ``retries`` override the instrument's; a command declared
``idempotent="false"`` is never sent twice (a lost or garbled reply is an error naming it).
A silent instrument (timeout, the port still open) is a ``HardwareError``: reopening the
port would not help. A port that is gone (an OS error on write or read: an unplugged USB
adapter, a closed pty) is ``DeviceGone``: the recovery reopens that port.
Every wait (light settle, chamber settle and soak) is bounded by the XML's timeouts and
cut short within 0.1 s by the run's stop/abort request (``ares.hardware.waits``).
"""

from __future__ import annotations

import math
import re
import time

from ares.errors import DeviceGone, HardwareError, ValueOutOfRange
from ares.hardware.waits import wait
from ares.hardware.line_protocol import (DEFAULT_CHAMBER, DEFAULT_LIGHT, DEFAULT_MONOCHROMATOR, DEFAULT_PHOTODIODE,
                                         DEFAULT_POWER_METER)


def range_text(lo: float | None, hi: float | None, unit: str) -> str:
    """``-20 .. 85 C``, ``>= 0 C`` or ``<= 85 C`` (a bound the XML does not give is open)."""
    if lo is not None and hi is not None:
        return f"{lo:g} .. {hi:g} {unit}".rstrip()
    return (f">= {lo:g} {unit}" if lo is not None else f"<= {hi:g} {unit}").rstrip()


class SerialInstrument:
    DEFAULT = DEFAULT_LIGHT
    ROLE = "light"  # the bench part a DeviceGone names (a recovery reopens this port, not another)

    def __init__(self, port, cfg, *, sleep=time.sleep, clock=time.monotonic):
        self.port, self.cfg, self._sleep, self._clock = port, cfg, sleep, clock
        self.name = cfg.name
        self.protocol = cfg.protocol or self.DEFAULT
        self.retried = 0  # commands that needed a retry (a noisy line shows here)
        # link statistics (ares.hardware.link_stats): commands sent (each attempt), replies
        # that were garbled (noise, partial line, bad echo, wrong form) and replies that never came
        self.commands = self.garbled = self.timeouts = 0
        self.ignored = self.streamed = 0  # unsolicited lines skipped: declared status/async, streamed readings
        self.ident: str | None = None  # the answer to the declared 'identify' command at connect

    def _wait(self, seconds: float, cancel=None) -> None:
        wait(seconds, cancel, sleep=self._sleep, clock=self._clock)

    @classmethod
    def _port(cls, cfg):
        import serial

        if cfg.port.startswith("aresemu://") and "ares.hardware.emulators" not in serial.protocol_handler_packages:
            serial.protocol_handler_packages.append("ares.hardware.emulators")
        try:
            return serial.serial_for_url(cfg.port, baudrate=cfg.baud, bytesize=cfg.bytesize, parity=cfg.parity,
                                         stopbits=cfg.stopbits, timeout=cfg.timeout_s)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DeviceGone(f"{cfg.name}: cannot open serial port {cfg.port} ({exc})", cls.ROLE) from None

    @classmethod
    def open(cls, cfg, **kw):
        """Open the port and ``connect()``."""
        inst = cls(cls._port(cfg), cfg, **kw)
        try:
            inst.connect()
        except BaseException:
            inst.close()
            raise
        return inst

    def connect(self) -> None:
        """Ask the instrument who it is when the system XML's ``<protocol>`` declares an
        ``identify`` command (``*IDN?``): the answer goes into the run record
        (``identity()``), and an instrument that does not answer is found at open, not in
        the middle of a scan."""
        if self.cfg.protocol is not None and self.cfg.protocol.command("identify") is not None:
            self.ident = self.identify()

    def _line(self, timeout: float | None = None) -> bytes:
        term = self.protocol.reply_terminator.encode("ascii")
        if timeout is not None and getattr(self.port, "timeout", None) is not None and self.port.timeout != timeout:
            try:  # (the wait left for this command: its own timeout less the lines skipped)
                self.port.timeout = timeout
            except (AttributeError, ValueError):  # a port (a test's fake) whose timeout is fixed
                pass
        read_until = getattr(self.port, "read_until", None)
        return read_until(term) if read_until is not None else self.port.readline()

    def _exchange(self, command: str, cmd=None) -> str | None:
        """One attempt: flush, send, (echo,) reply line -- past the unsolicited lines the
        protocol declares. None: no whole line in time (``cmd.timeout_s`` or the instrument's)."""
        p = self.protocol
        term = p.reply_terminator.encode("ascii")
        timeout = cmd.timeout_s if cmd is not None and cmd.timeout_s is not None else self.cfg.timeout_s
        self.commands += 1
        try:
            flush = getattr(self.port, "reset_input_buffer", None)
            if flush is not None:  # a late reply to an earlier command must not answer this one
                flush()
            # the reply's time counts from the command: an emulator that holds the bench's clock
            # until it answers (*OPC? while the grating moves) is timed as a blocking query is
            deadline = self._clock() + timeout
            self.port.write((command + p.terminator).encode("ascii"))
            echoed = not p.echo
            while True:
                left = deadline - self._clock()
                if left <= 0:
                    return None
                line = self._line(left)
                if not line.endswith(term):
                    return _garbled_check(line)  # (None: silence; bytes without the terminator: garbled)
                text = _text(line)
                if self._unsolicited(text, cmd):
                    continue
                if not echoed:
                    if text != command:
                        raise _Garbled(f"echo '{text}' of '{command}' is not the command (garbled)")
                    echoed = True
                    continue
                return text
        except OSError as exc:
            raise DeviceGone(f"{self.name} on {self.cfg.port}: port error on '{command}' ({exc})", self.ROLE) from None

    def _unsolicited(self, text: str, cmd) -> bool:
        """A line the instrument sent unasked: a declared status/async line, or a streamed
        reading when ``cmd`` does not take its reply from the stream."""
        p = self.protocol
        if any(re.fullmatch(pat, text) for pat in p.ignore):
            self.ignored += 1
            return True
        if p.stream is not None and not (cmd is not None and cmd.stream) and re.fullmatch(p.stream, text):
            self.streamed += 1
            return True
        return False

    def query(self, command: str, pattern: str | None = None, cmd=None):
        """Send ``command`` and return its reply (with ``pattern``: the match object),
        retrying a garbled or missing reply ``retries`` times (the command's, else the
        protocol's; never for a command declared ``idempotent="false"``)."""
        p = self.protocol
        retries = p.retries if cmd is None or cmd.retries is None else cmd.retries
        if cmd is not None and not cmd.idempotent:
            retries = 0  # sent twice it would act twice (a trigger, a toggle, a relative move)
        timeout = cmd.timeout_s if cmd is not None and cmd.timeout_s is not None else self.cfg.timeout_s
        for attempt in range(retries + 1):
            try:
                reply = self._exchange(command, cmd)
                if reply is None:
                    self.timeouts += 1
                    why = (f"no reply to '{command}' within {timeout:g} s (timeout: the instrument is "
                           "silent, its port open)")
                    continue
                _printable(reply, command)
                m = re.fullmatch(p.error, reply)
                if m:
                    text = m.groupdict().get("text") or reply
                    raise HardwareError(f"{self.name} on {self.cfg.port}: refused '{command}': {text.strip()}")
                if pattern is None:
                    return reply
                m = re.fullmatch(pattern, reply)
                if m is not None:
                    return m
                why = f"reply '{reply}' to '{command}' does not match '{pattern}' (wrong reply)"
                self.garbled += 1
            except _Garbled as exc:
                why = str(exc)
                self.garbled += 1
            finally:
                if attempt:
                    self.retried += 1
        tries = f" after {retries + 1} attempts" if retries else ""
        if cmd is not None and not cmd.idempotent:
            tries += f" (not sent again: '{cmd.name}' is declared idempotent=\"false\")"
        raise HardwareError(f"{self.name} on {self.cfg.port}: {why}{tries}")

    def _do(self, name: str, value: float | None = None) -> str:
        """Send command ``name`` of the protocol; the reply must match its pattern. Returns the
        ``value`` group (or the whole reply)."""
        c = self.protocol.command(name)
        if c is None:
            raise HardwareError(f"{self.name} on {self.cfg.port}: its <protocol> has no '{name}' command")
        m = self.query(c.send.format(value=value), c.reply, c)
        return m.groupdict().get("value") or m.group(0)

    def _number(self, name: str) -> float:
        got = self._do(name)
        try:
            v = float(got)
        except ValueError:
            v = math.nan
        if not math.isfinite(v):
            raise HardwareError(f"{self.name} on {self.cfg.port}: reply '{got}' to "
                                f"'{self.protocol.command(name).send}' is not a number")
        return v

    def _check(self, value: float, what: str, unit: str) -> float:
        value = float(value)
        lo, hi = self.cfg.min, self.cfg.max
        if not math.isfinite(value) or (lo is not None and value < lo) or (hi is not None and value > hi):
            raise ValueOutOfRange(f"{self.name}: {what} {value:g} {unit} is outside {range_text(lo, hi, unit)}")
        return value

    def identify(self) -> str:
        return self._do("identify")

    def link_counters(self) -> dict:
        """The link statistics since open (``ares.hardware.link_stats``)."""
        out = {"commands": self.commands, "retries": self.retried, "garbled": self.garbled, "timeouts": self.timeouts}
        if self.protocol.ignore or self.protocol.stream:  # an instrument that talks unprompted: what was skipped
            out.update(ignored_lines=self.ignored, streamed_lines=self.streamed)
        return out

    def identity(self) -> dict:
        """The port and what the instrument answered to its identify command at connect."""
        out = {"interface": "serial", "port": self.cfg.port}
        if self.ident:
            out["idn"] = self.ident
        return out

    def close(self) -> None:
        self.port.close()

    def reconnect(self) -> None:
        """Open the port again and ask for the identification (``DeviceGone`` while away)."""
        try:
            self.port.close()
        except Exception:  # noqa: BLE001 -- a port that is gone may not close cleanly
            pass
        self.port = self._port(self.cfg)
        self.connect()


class _Garbled(Exception):
    """A reply line that is not the instrument speaking its protocol (line noise)."""


def _text(line: bytes) -> str:
    return line.decode("ascii", "replace").strip()


def _printable(reply: str, command: str) -> None:
    bad = [c for c in reply if not (" " <= c <= "~" or c == "\t")]
    if bad:
        raise _Garbled(f"reply {reply!r} to '{command}' holds bytes that are not printable ASCII (garbled)")


def _garbled_check(line: bytes) -> None:
    """A partial line without its terminator: garbled when bytes came, else silence (None)."""
    if line:
        raise _Garbled(f"partial reply {_text(line)!r} without its terminator (garbled)")
    return None


class SerialLightSource(SerialInstrument):
    def set_level(self, level: float) -> None:
        self._do("set", self._check(level, "light level", self.cfg.unit or ""))

    def get_level(self) -> float:
        """The driver's set point, as the instrument answers ``get``."""
        return self._number("get")

    def read_level(self) -> float | None:
        """The output the source measures (its monitor photodiode: the ``read`` command of its
        ``<protocol>``), None when it declares none -- ``get`` only echoes the set point."""
        return self._number("read") if self.protocol.command("read") is not None else None

    @property
    def level_tolerance(self) -> float | None:
        """``<light_source tolerance>``: how far the readback may be from the set point (its unit)."""
        return self.cfg.tolerance

    def settle(self, cancel=None) -> None:
        self._wait(self.cfg.settle_s, cancel)


class SerialChamber(SerialInstrument):
    DEFAULT = DEFAULT_CHAMBER
    ROLE = "chamber"
    _setpoint: float | None = None
    last_reading: float | None = None  # the temperature read last while settling

    def set_temperature(self, celsius: float) -> None:
        v = self._check(celsius, "temperature", "C")
        self._do("set", v)
        self._setpoint = v

    def get_temperature(self) -> float:
        return self._number("get")

    def _at_setpoint(self) -> tuple[bool, str]:
        tol = self.cfg.tolerance
        if tol is None or self._setpoint is None:
            if self.protocol.command("stable") is None:
                raise HardwareError(f"{self.name} on {self.cfg.port}: give tolerance= (C) or a 'stable' command "
                                    "in its <protocol> to know when it has settled")
            return self._do("stable").strip() == "1", "it never reported stable"
        t = self.last_reading = self.get_temperature()  # (the run records it: set point and readback)
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


class SerialMonochromator(SerialInstrument):
    """The spectral bench's wavelength-selectable light (EMVA 1288 4.0 Linear, Section 9.1):
    ``set``/``get`` the wavelength in nm (range-checked against the XML's min/max), and the
    FWHM bandwidth when its protocol has a ``bandwidth`` command (NaN without). A grating move
    takes time (the set command of a Cornerstone is overlapped: answered before the move ends):
    a ``complete`` command (IEEE 488.2 ``*OPC?``, answered when the move is done) is waited on by
    ``settle`` before its ``settle_s`` soak; ``completion`` says whether the instrument told."""

    completion = False  # the last settle asked the instrument whether its move was complete

    DEFAULT = DEFAULT_MONOCHROMATOR
    ROLE = "monochromator"

    def set_wavelength(self, nm: float) -> None:
        self._do("set", self._check(nm, "wavelength", "nm"))

    def get_wavelength(self) -> float:
        return self._number("get")

    def bandwidth(self) -> float:
        return self._number("bandwidth") if self.protocol.command("bandwidth") is not None else math.nan

    def settle(self, cancel=None) -> None:
        self.completion = self.protocol.command("complete") is not None
        if self.completion:  # its reply comes when the move is done (give the command a timeout_s that covers one)
            self._do("complete")
        self._wait(self.cfg.settle_s, cancel)


class SerialPhotodiode(SerialInstrument):
    """The calibrated reference photodiode on its meter: ``read()`` is one reading (A, or W
    for ``reading="power"``); ``set_wavelength`` tells a power meter the wavelength its
    correction applies to (protocol command ``wavelength``, when it has one)."""

    DEFAULT = DEFAULT_PHOTODIODE
    ROLE = "photodiode"

    def __init__(self, port, cfg, *, reading: str = "current", **kw):
        super().__init__(port, cfg, **kw)
        if cfg.protocol is None and reading == "power":
            self.protocol = DEFAULT_POWER_METER

    @classmethod
    def open(cls, cfg, reading: str = "current", **kw):
        return super().open(cfg, reading=reading, **kw)

    def read(self) -> float:
        return self._number("read")

    def set_wavelength(self, nm: float) -> None:
        if self.protocol.command("wavelength") is not None:
            self._do("wavelength", float(nm))
