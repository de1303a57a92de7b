"""The interfaces every backend implements: I2C/USB/serial hardware, replay, simulator.

Shapes only; no backend code here. A ``Bench`` is the composition a system XML declares.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class RegisterBus(Protocol):
    """Raw register access (I2C, SPI, a simulator's register file)."""

    name: str

    def read(self, address: int) -> int: ...

    def write(self, address: int, value: int) -> None: ...


@dataclass
class Frame:
    """One frame: 2-D unsigned integer data in DN plus metadata."""

    data: np.ndarray
    index: int = 0
    timestamp: float = 0.0
    meta: dict = field(default_factory=dict)


@runtime_checkable
class FrameSource(Protocol):
    """Delivers frames of a fixed shape; raises ``FrameError``/``DeviceGone`` on faults."""

    name: str
    shape: tuple[int, int]
    bit_depth: int

    def grab(self, n: int) -> Iterator[Frame]: ...

    # Optional: ``release()`` -- no frames are wanted for a while (a large stage is being
    # analysed); free what the source caches for its current settings. The runner calls it
    # when present.
    # Optional: ``exposure_paced`` (default True) -- frames come no faster than the
    # exposure, as from a real sensor; False for sources that compute or read their frames
    # (the simulator, replays). The time remaining charges a frame its exposure + readout
    # only when True.
    # Optional: ``recorded`` (default False) -- the frames are a recording (a replay): no probe
    # frames are taken to prove the bench settled (ares.scan.settling).
    # Optional: ``frame_cost(fields) -> float`` -- the relative cost of making a frame with
    # these settings (register field -> physical value, ``light``, ``temperature``), and
    # ``compute_seconds`` -- wall seconds spent making frames so far: a source whose frame
    # time follows its work, not the exposure (the simulator), lets the time remaining
    # charge each stage to come by its own cost.


@runtime_checkable
class LightSource(Protocol):
    """A light source; ``level`` is in the unit the system XML declares
    (the simulator uses photons per pixel per second at the sensor)."""

    name: str

    def set_level(self, level: float) -> None: ...

    def get_level(self) -> float: ...

    def settle(self, cancel=None) -> None: ...


@runtime_checkable
class Chamber(Protocol):
    """A thermal chamber; temperatures in degrees Celsius."""

    name: str

    def set_temperature(self, celsius: float) -> None: ...

    def get_temperature(self) -> float: ...

    def settle(self, cancel=None) -> None: ...


@runtime_checkable
class Monochromator(Protocol):
    """Wavelength-selectable light (nm); ``bandwidth()`` is its FWHM in nm (NaN if unknown)."""

    name: str

    def set_wavelength(self, nm: float) -> None: ...

    def get_wavelength(self) -> float: ...

    def bandwidth(self) -> float: ...

    def settle(self, cancel=None) -> None: ...


@runtime_checkable
class Photodiode(Protocol):
    """A calibrated reference photodiode's meter: ``read()`` in A (or W: a power meter)."""

    name: str

    def read(self) -> float: ...

    def set_wavelength(self, nm: float) -> None: ...


@dataclass
class Bench:
    """What a scan drives: the sensor's registers, a frame source, optional instruments."""

    registers: "RegisterFile"  # noqa: F821 -- ares.hardware.registers.RegisterFile
    frames: FrameSource
    light: LightSource | None = None
    chamber: Chamber | None = None
    info: dict = field(default_factory=dict)
    closers: list = field(default_factory=list)  # called after the devices close (emulators unregister)
    monochromator: Monochromator | None = None  # spectral bench (EMVA 1288 4.0 Linear, Section 9)
    photodiode: Photodiode | None = None
    recovery_clock: object = None  # the clock a device's absence is waited on (emulated time), None: the host's
    clock: object = None  # the bench's time (``now()``, ``sleep(s)``): simulated on the simulator, else None (the host's)

    def reconnect(self, device: str = "frames") -> None:
        """Find the bench part that failed again after it was unplugged: ``device`` is
        ``DeviceGone.device`` ("frames", "registers", "light", "chamber"); only that part is
        reopened. ``DeviceGone`` while it is still away; ``HardwareError`` when it cannot be
        looked for at all (no reconnect: waiting would not help)."""
        from ares.errors import HardwareError

        part = {"frames": self.frames, "registers": getattr(self.registers, "bus", None), "light": self.light,
                "chamber": self.chamber, "monochromator": self.monochromator,
                "photodiode": self.photodiode}.get(device)
        if device == "registers":  # every I2C device declared (an adapter unplugged takes them all)
            for other in _other_buses(self.registers):
                other.reconnect()
        again = getattr(part, "reconnect", None)
        if again is None:
            name = getattr(part, "name", device)
            raise HardwareError(f"{name}: cannot reconnect (this {device} device has no reconnect)")
        again()

    def close(self) -> None:
        for dev in (self.frames, self.light, self.chamber, self.monochromator, self.photodiode, self.registers.bus,
                    *_other_buses(self.registers)):
            close = getattr(dev, "close", None)
            if callable(close):
                close()
        for fn in self.closers:
            fn()


def _other_buses(registers) -> list:
    """The register file's I2C devices beside the sensor's own (``RegisterFile.buses``)."""
    main = getattr(registers, "bus", None)
    return [b for b in getattr(registers, "buses", {}).values() if b is not main]
