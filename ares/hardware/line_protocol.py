"""A serial instrument's line protocol as the system XML declares it (``<protocol>``), and
the built-in dialect used when it declares none. Pure data: ``ares.protocol.devices``
reads it from XML, ``ares.hardware.serial_instruments`` speaks it."""

from __future__ import annotations

from dataclasses import dataclass


# An identity (``*IDN?``): two to four comma-separated fields (IEEE 488.2: maker, model,
# serial, firmware) of letters, digits and ``.+-/:`` -- a garbled line ('?#%') is not one.
IDN_PATTERN = r"[\w .+/-]+(?:,[\w .+/:-]*){1,3}"
GARBLED_PROBE = "?#%"  # a reply an identify pattern must refuse (ares.protocol.devices checks it)


@dataclass(frozen=True)
class Command:
    """``<command name send reply timeout_s retries idempotent stream>``: ``send`` is a
    template (``{value}`` and format specs as in Python: ``LEVEL {value:.6g}``); ``reply`` is a
    regular expression the whole reply line must match (a group ``value`` carries a number
    back). ``timeout_s``: this command's reply timeout (default: the instrument's);
    ``retries``: this command's (default: the protocol's); ``idempotent="false"``: never sent
    twice (a trigger, a shutter toggle, a relative move -- a lost reply is an error, not a
    retry); ``stream="true"``: the reply is the instrument's next streamed reading."""

    name: str
    send: str
    reply: str
    timeout_s: float | None = None
    retries: int | None = None
    idempotent: bool = True
    stream: bool = False


@dataclass(frozen=True)
class LineProtocol:
    terminator: str = "\n"  # after each command
    reply_terminator: str = "\n"  # ends each reply line
    error: str = r"ERR\s*(?P<text>.*)"  # a reply matching this is the instrument refusing
    commands: tuple[Command, ...] = ()
    echo: bool = False  # the instrument sends each command line back before its reply
    retries: int = 0  # further attempts after a garbled or missing reply (never after an error reply)
    ignore: tuple[str, ...] = ()  # <ignore pattern>: unsolicited lines (status, async notices) skipped
    stream: str | None = None  # <stream pattern>: readings the instrument sends unasked; never a reply
    #   unless the command says stream="true"

    def command(self, name: str) -> Command | None:
        return next((c for c in self.commands if c.name == name), None)


# The dialect ARES spoke before protocols were declared (and its emulators speak).
DEFAULT_LIGHT = LineProtocol(commands=(
    Command("identify", "*IDN?", IDN_PATTERN), Command("set", "LEVEL {value:.6g}", "OK"),
    Command("get", "LEVEL?", r"(?P<value>\S+)")))
DEFAULT_CHAMBER = LineProtocol(commands=(
    Command("identify", "*IDN?", IDN_PATTERN), Command("set", "TEMP {value:.2f}", "OK"),
    Command("get", "TEMP?", r"(?P<value>\S+)"), Command("stable", "STABLE?", r"(?P<value>[01])")))
# Spectral bench (EMVA 1288 4.0 Linear, Section 9.1): a monochromator in an Oriel/Newport
# Cornerstone-like dialect, a reference photodiode on a Thorlabs PM100-like (SCPI) meter.
DEFAULT_MONOCHROMATOR = LineProtocol(commands=(
    Command("identify", "*IDN?", IDN_PATTERN), Command("set", "GOWAVE {value:.2f}", "OK"),
    Command("get", "WAVE?", r"(?P<value>\S+)"), Command("bandwidth", "BANDPASS?", r"(?P<value>\S+)"),
    Command("complete", "*OPC?", "1", timeout_s=30.0)))  # answered when the grating's move is done
DEFAULT_PHOTODIODE = LineProtocol(commands=(
    Command("identify", "*IDN?", IDN_PATTERN), Command("read", "MEAS:CURR?", r"(?P<value>\S+)"),
    Command("wavelength", "SENS:CORR:WAV {value:.1f};*OPC?", "1")))
DEFAULT_POWER_METER = LineProtocol(commands=(
    Command("identify", "*IDN?", IDN_PATTERN), Command("read", "MEAS:POW?", r"(?P<value>\S+)"),
    Command("wavelength", "SENS:CORR:WAV {value:.1f};*OPC?", "1")))
