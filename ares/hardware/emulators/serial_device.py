"""Emulated serial instruments: a light source and a thermal chamber that answer ARES's
built-in line dialect (``ares.hardware.line_protocol``), in front of the simulator's light
and chamber. A host opens them as the pyserial URL ``aresemu://NAME`` (``protocol_aresemu``)
after ``register(NAME, instrument)``.

The spectral bench's monochromator (``GOWAVE nm``/``WAVE?``/``BANDPASS?``, Oriel/Newport
Cornerstone-like) and reference photodiode meter (``MEAS:CURR?``, ``MEAS:POW?``,
``SENS:CORR:WAV nm;*OPC?``, Thorlabs PM100-like SCPI) answer in front of the simulator's
(``ares.sim.spectral``).

Faults (``--sim-fault`` keys, ROLE = ``light`` or ``chamber``; ``monochromator`` and ``photodiode``
in a faults dict given to their emulators, N = 0-based command count):
``ROLE_timeout_at`` (no reply), ``ROLE_wrong_reply_at`` (a reply of the wrong form),
``ROLE_error_at`` (``ERR`` reply), ``ROLE_disconnect_at`` (the port is gone from then on),
``ROLE_late_at`` (the reply comes after the host's read timed out: it waits in the input buffer).

``changes`` (the light, the chamber, the monochromator's ``GOWAVE``): every ``LEVEL`` (``TEMP``) command's level, when it came (``commanded_s``) and when the
output reached it (``settled_s``: within the monitor's accuracy; later than the command for an LED
relaxing with ``light_tau_s``), on the bench's clock -- the device's truth of a light change.

``ROLE_chatty`` = SEED: an instrument that talks unprompted (issue 49) -- before a reply come
0 to 2 lines it sends on its own, drawn with that seed: a status line (``STATUS 25.00 C OK``,
as one sent every 0.3 s would land), an asynchronous ``SETTLED`` notice and a streamed
reading (``+1.2345E-03``, a bare number as a streaming meter sends). A host that declares
them (``<ignore>``, ``<stream>``) skips them; one that does not takes them for the reply.
"""

from __future__ import annotations

import random
import threading

from ares.errors import AresError

_REGISTRY: dict[str, "EmulatedInstrument"] = {}
_LOCK = threading.Lock()


def register(name: str, instrument: "EmulatedInstrument") -> None:
    with _LOCK:
        _REGISTRY[name] = instrument


def unregister(name: str, instrument: "EmulatedInstrument") -> None:
    with _LOCK:
        if _REGISTRY.get(name) is instrument:
            del _REGISTRY[name]


def lookup(name: str) -> "EmulatedInstrument | None":
    with _LOCK:
        return _REGISTRY.get(name)


def faults_for(role: str) -> tuple[str, ...]:
    return tuple(f"{role}_{k}" for k in ("timeout_at", "wrong_reply_at", "error_at", "disconnect_at", "late_at",
                                         "chatty"))


class Chatty(list):
    """Lines the instrument sends before its reply (the reply last)."""


class Late(str):
    """A reply that arrives only after the host's read has timed out (``ROLE_late_at``)."""


FAULTS = faults_for("light") + faults_for("chamber")  # (the spectral devices' emulators take their ROLE_ keys
#   from a faults dict given to them; the command line's --sim-fault does not offer them yet)


class EmulatedInstrument:
    """Line in, line out (``None`` = no reply); ``device`` is the simulator's instrument."""

    role = "light"
    ident = "ARES,EMULATED-LED,0,1.0"

    def __init__(self, device, faults: dict | None = None, clock=None):
        self.device = device
        self.clock = clock  # the bench's clock (the simulator's): when its output changed
        self.changes: list[dict] = []  # (the light) every LEVEL command: level, commanded_s, settled_s
        keys = faults_for(self.role)
        self.faults = {k[len(self.role) + 1:]: int(v) for k, v in (faults or {}).items() if k in keys}
        self.commands = 0
        self.gone = False
        self.log: list[str] = []
        seed = self.faults.get("chatty")
        self._chat = random.Random(seed) if seed is not None else None

    def handle(self, line: str):
        reply = self._handle(line)
        if self._chat is None or reply is None or isinstance(reply, Late):
            return reply
        said = [self._chat.choice((f"STATUS {25 + self._chat.random():.2f} C OK", "SETTLED",
                                   f"{self._chat.uniform(-1, 1) * 1e-3:+.4E}"))
                for _ in range(self._chat.choice((0, 1, 1, 2)))]
        return Chatty(said + [reply])

    def _handle(self, line: str) -> str | None:
        n = self.commands
        self.commands += 1
        self.log.append(line)
        if n == self.faults.get("disconnect_at"):
            self.gone = True
        if self.gone:
            raise OSError(5, "Input/output error (port gone)")
        if n == self.faults.get("timeout_at"):
            return None
        if n == self.faults.get("late_at"):
            cmd, _, arg = line.strip().partition(" ")
            return Late(self.answer(cmd.upper(), arg.strip()))
        if n == self.faults.get("wrong_reply_at"):
            return "?#%"
        if n == self.faults.get("error_at"):
            return "ERR emulated fault"
        cmd, _, arg = line.strip().partition(" ")
        try:
            return self.answer(cmd.upper(), arg.strip())
        except (ValueError, AresError) as exc:
            return f"ERR {exc}"

    def answer(self, cmd: str, arg: str) -> str:
        if cmd == "*IDN?":
            return self.ident
        if cmd == "LEVEL":
            before = self.device.read_level() if hasattr(self.device, "read_level") else None
            self.device.set_level(float(arg))
            self._record(before, float(arg))
            return "OK"
        if cmd == "LEVEL?":  # the driver's set point
            return repr(float(self.device.get_level()))
        if cmd == "MON?" and hasattr(self.device, "read_level"):  # its monitor photodiode: the output now
            return repr(float(self.device.read_level()))
        return f"ERR unknown command '{cmd}'"


    def _record(self, before: float | None, level: float) -> None:
        """The device's truth of a light change: when it was commanded and when its output
        (``level_at``: an LED relaxing with its time constant) was within the monitor's accuracy
        (``readback_rtol`` of the larger of the two levels) of the new level, on the bench's clock."""
        if self.clock is None:
            return
        t0 = self.clock.now()
        at = getattr(self.device, "level_at", None)
        tol = getattr(self.device, "readback_rtol", 0.0) * max(abs(level), abs(before or 0.0))
        done = (lambda dt: abs(at(t0 + dt) - level) <= tol) if at is not None else (lambda dt: True)
        lo, hi = 0.0, 0.0
        if not done(0.0):  # a ramp: the first time within tolerance, by doubling then bisection
            hi = 1e-6
            while not done(hi) and hi < 1e6:
                lo, hi = hi, 2 * hi
            for _ in range(60):
                mid = (lo + hi) / 2
                lo, hi = (lo, mid) if done(mid) else (mid, hi)
        self.changes.append({"level": level, "commanded_s": t0, "settled_s": t0 + hi})


class EmulatedChamber(EmulatedInstrument):
    role = "chamber"
    ident = "ARES,EMULATED-CHAMBER,0,1.0"

    def answer(self, cmd: str, arg: str) -> str:
        if cmd == "TEMP":
            self.device.set_temperature(float(arg))
            self._record(None, float(arg))  # (the simulator's chamber is there at once)
            return "OK"
        if cmd == "TEMP?":
            return repr(float(self.device.get_temperature()))
        if cmd == "STABLE?":
            return "1"
        return super().answer(cmd, arg)


class EmulatedMonochromator(EmulatedInstrument):
    """``GOWAVE nm`` starts the grating's move and is answered at once (an overlapped command, as a
    Cornerstone's); ``WAVE?`` is the drive's position now (mid-move: where it is); ``*OPC?`` answers
    ``1`` when the move is complete -- the drive stopped and rung out -- and the reply comes then
    (the bench's clock moves on to it, as a blocking query holds the host). With the bench's clock
    ``changes`` keeps every ``GOWAVE``: its wavelength (``level``), ``commanded_s`` and ``settled_s``
    (the device's ``settled_at``: its truth of a wavelength change)."""

    role = "monochromator"
    ident = "ARES,EMULATED-CS130,0,1.0"

    def answer(self, cmd: str, arg: str) -> str:
        if cmd == "GOWAVE":
            self.device.set_wavelength(float(arg))
            if self.clock is not None:
                now = self.clock.now()
                self.changes.append({"level": float(arg), "commanded_s": now,
                                     "settled_s": max(float(getattr(self.device, "settled_at", now)), now)})
            return "OK"
        if cmd == "*OPC?":
            left = float(getattr(self.device, "settled_at", 0.0)) - self.clock.now() if self.clock is not None else 0.0
            if left > 0:
                self.clock.sleep(left)
            return "1"
        if cmd == "WAVE?":
            return f"{self.device.get_wavelength():.3f}"
        if cmd == "BANDPASS?":
            return f"{self.device.bandwidth():.2f}"
        if cmd == "*IDN?":
            return self.ident
        return f"ERR unknown command '{cmd}'"


class EmulatedPowerMeter(EmulatedInstrument):
    role = "photodiode"
    ident = "ARES,EMULATED-PM100,0,1.0"

    def answer(self, cmd: str, arg: str) -> str:
        if cmd in ("MEAS:CURR?", "MEAS:POW?"):
            want = "current" if cmd == "MEAS:CURR?" else "power"
            if want != self.device.reading:
                return f"ERR this meter's sensor reads {self.device.reading}"
            return f"{self.device.read():.6E}"
        if cmd == "SENS:CORR:WAV":
            self.device.set_wavelength(float(arg.split(";", 1)[0]))
            return "1"
        if cmd == "*IDN?":
            return self.ident
        return f"ERR unknown command '{cmd}'"
