"""The Instrumentation tab's bench between scans (no Qt): open the devices a system XML
declares (or the simulated bench), read and write register fields by name within the
register map's limits, set the light level and the chamber set point, grab a frame.

Every device error is one ``AresError`` sentence naming the device (the view shows it).
A scan opens its own bench, so the window closes this one before a scan starts: a real
device is never opened twice. Values written here act on the bench now; a scan starts
from its own ``<settings>`` and the register defaults.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ares.errors import InputError

from ares.gui.models.observable import Observable


@dataclass(frozen=True)
class FieldRow:
    name: str
    value: float | None  # physical; None for a write-only field or before a read
    unit: str
    minimum: float | None
    maximum: float | None
    access: str
    description: str

    @property
    def limits(self) -> str:
        lo = "" if self.minimum is None else f"{self.minimum:g}"
        hi = "" if self.maximum is None else f"{self.maximum:g}"
        return f"{lo} .. {hi}" if lo or hi else ""


class InstrumentSession(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.path: str | None = None
        self.system = None
        self.bench = None
        self.values: dict[str, float] = {}
        self.message = "Not connected."

    @property
    def connected(self) -> bool:
        return self.bench is not None

    def choose(self, path: str | Path) -> None:
        """Use the system XML at ``path`` (checked now; InputError with file:line)."""
        from ares.protocol import load_system

        self.close()
        self.system = load_system(path)
        self.path = str(path)
        self.values = {}
        self.message = f"{Path(path).name}: {self.system.name}, not connected."
        self._changed()

    def open(self) -> None:
        """Open the bench the chosen system declares and read every readable field."""
        from ares.rig.factory import build_bench

        if self.system is None:
            raise InputError("choose a system XML first")
        self.close()
        self.bench = build_bench(self.system)
        self.message = f"Connected to {self.system.name}."
        self.read_all()

    def close(self) -> None:
        bench, self.bench = self.bench, None
        if bench is not None:
            bench.close()
            self.message = f"{self.system.name}: disconnected."
            self._changed()

    def _need_bench(self):
        if self.bench is None:
            raise InputError("the bench is not connected: press Connect first")
        return self.bench

    def fields(self) -> list[FieldRow]:
        if self.system is None or self.system.registers is None:
            return []
        return [FieldRow(f.name, self.values.get(f.name), f.unit, f.minimum, f.maximum, f.access, f.description)
                for f in self.system.registers.fields]

    def read_all(self) -> None:
        self.values = dict(self._need_bench().registers.snapshot())
        self._changed()

    def write(self, name: str, value: float | str) -> float | None:
        """Write a field's physical value (range-checked by the register map); returns
        the value read back (None for a write-only field)."""
        regs = self._need_bench().registers
        f = regs.map.field(name)  # UnknownRegister names the known fields
        if f.access == "ro":
            raise InputError(f"register field '{name}' is read-only")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise InputError(f"register field '{name}': '{value}' is not a number") from None
        if not math.isfinite(v):
            raise InputError(f"register field '{name}': {value} is not a finite number")
        regs.set(name, v)
        back = None if f.access == "wo" else regs.get(name)
        if back is not None:
            self.values[name] = back
        self.message = f"{name} = {v:g} {f.unit}".rstrip() + " written" + (
            f", read back {back:g}." if back is not None else ".")
        self._changed()
        return back

    def set_light(self, level: float) -> None:
        bench = self._need_bench()
        if bench.light is None:
            raise InputError(f"{self.system.name} declares no light source")
        dev = self.system.light_source
        _check_range("light level", level, dev)
        bench.light.set_level(float(level))
        self.message = f"Light level set to {level:g}" + (f" {dev.unit}" if dev is not None and dev.unit else "") + "."
        self._changed()

    def set_chamber(self, celsius: float) -> None:
        bench = self._need_bench()
        if bench.chamber is None:
            raise InputError(f"{self.system.name} declares no thermal chamber")
        _check_range("chamber set point", celsius, self.system.chamber)
        bench.chamber.set_temperature(float(celsius))
        self.message = f"Chamber set point {celsius:g} °C."
        self._changed()

    def readings(self) -> dict[str, str]:
        """Light level and chamber temperature as the devices report them now."""
        out = {}
        if self.bench is not None:
            if self.bench.light is not None:
                out["light level"] = f"{self.bench.light.get_level():g}"
            if self.bench.chamber is not None:
                out["chamber"] = f"{self.bench.chamber.get_temperature():.2f} °C"
        return out

    def grab(self):
        """One frame from the bench (2-D array, DN)."""
        return next(iter(self._need_bench().frames.grab(1))).data


def _check_range(what: str, value: float, dev) -> None:
    if not math.isfinite(value):
        raise InputError(f"{what}: {value} is not a finite number")
    lo, hi = (getattr(dev, "min", None), getattr(dev, "max", None)) if dev is not None else (None, None)
    if lo is not None and value < lo or hi is not None and value > hi:
        raise InputError(f"{what} {value:g} is outside {getattr(dev, 'name', 'the device')}'s range {lo:g}..{hi:g}")
