"""Named register fields over a raw ``RegisterBus``.

A field occupies bits ``lsb..msb`` of a value made of ``count`` consecutive registers
(combined big- or little-endian, as the map declares), and maps its raw integer to a
physical value as ``physical = offset + scale * raw``. Limits are physical.
Pure Python: the XML loader in ``ares.protocol`` builds these objects.
"""

from __future__ import annotations

from dataclasses import dataclass

from contextlib import contextmanager

from ares.errors import HardwareError, UnknownRegister, ValueOutOfRange, InputError


READ_TRIES = 4  # reads of a multi-register value before it is called unreadable (it changed during each)


@contextmanager
def _nothing():
    yield


@contextmanager
def _naming(name: str):
    """A bus error inside a field access names the field too (the bus knows only addresses)."""
    try:
        yield
    except HardwareError as exc:
        again = type(exc)(f"{exc} (field '{name}')")
        again.__dict__.update(exc.__dict__)  # which device failed (DeviceGone.device), a loss's kind
        raise again from None


@dataclass(frozen=True)
class Field:
    name: str
    address: int
    lsb: int = 0
    msb: int = 7
    count: int = 1  # number of consecutive registers the value spans
    access: str = "rw"  # "rw", "ro" or "wo"
    scale: float = 1.0
    offset: float = 0.0
    unit: str = ""
    minimum: float | None = None  # physical
    maximum: float | None = None  # physical
    default: int = 0  # raw
    description: str = ""
    volatile: bool = False  # the device changes it (self-clearing, status): a write is not verified by read-back
    signed: bool = False  # two's complement raw value (a GenICam feature's -3 dB, a signed offset register)
    bus: str | None = None  # the <i2c name> of the device it lives on (None: the register map's bus)
    buffered: str | None = None  # double-buffered: "shadow" (read back at ``shadow``) or "frame" (takes
    #   effect at the next frame boundary: verified after a frame has arrived)
    shadow: int | None = None  # buffered="shadow": the address the pending value reads back at

    @property
    def width(self) -> int:
        return self.msb - self.lsb + 1

    @property
    def mask(self) -> int:
        return ((1 << self.width) - 1) << self.lsb

    def check(self, physical: float) -> None:
        """``ValueOutOfRange`` (one sentence) when ``physical`` is outside the field's limits."""
        if self.minimum is not None and physical < self.minimum - 1e-12 * max(1.0, abs(self.minimum)):
            raise ValueOutOfRange(
                f"register field '{self.name}': {physical:g} {self.unit} is below its minimum {self.minimum:g}".rstrip()
            )
        if self.maximum is not None and physical > self.maximum + 1e-12 * max(1.0, abs(self.maximum)):
            raise ValueOutOfRange(
                f"register field '{self.name}': {physical:g} {self.unit} is above its maximum {self.maximum:g}".rstrip()
            )

    def to_raw(self, physical: float) -> int:
        """Physical value -> raw integer, range-checked (one clear sentence on failure)."""
        self.check(physical)
        raw = round((physical - self.offset) / self.scale)
        lo, hi = (-(1 << (self.width - 1)), 1 << (self.width - 1)) if self.signed else (0, 1 << self.width)
        if raw < lo or raw >= hi:
            raise ValueOutOfRange(
                f"register field '{self.name}': {physical:g} needs raw value {raw}, "
                f"which does not fit in {self.width} {'signed ' if self.signed else ''}bits"
            )
        return int(raw) & ((1 << self.width) - 1)  # (signed: two's complement on the wire)

    def to_physical(self, raw: int) -> float:
        if self.signed and raw >= 1 << (self.width - 1):
            raw -= 1 << self.width
        return self.offset + self.scale * raw


def latching_address(f: Field, endian: str, latch: str | None) -> int | None:
    """The register of a multi-register field whose read latches the others (``latch`` "msb"
    or "lsb": its most or least significant; registers combined ``endian``), None without one."""
    if not latch or f.count < 2:
        return None
    return f.address if (latch == "msb") == (endian == "big") else f.address + f.count - 1


@dataclass(frozen=True)
class RegisterMap:
    address_bits: int = 16
    value_bits: int = 16
    endian: str = "big"  # order of multi-register values: "big" = lowest address is most significant
    fields: tuple[Field, ...] = ()
    bus: str | None = None  # the <i2c name> the sensor's registers are on (None: the first declared)
    group_hold: tuple[int, int, int] | None = None  # (register, hold value, release value): a multi-register
    #   value is written between them, so the sensor never latches half of it
    read_latch: str | None = None  # "msb"/"lsb": reading that register of a multi-register value latches the
    #   others until they are read (read once, that one first); None: read consistently by reading again

    def __post_init__(self):
        names = [f.name for f in self.fields]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise InputError(f"register map declares field(s) {sorted(dup)} more than once")
        for f in self.fields:
            if f.msb >= self.value_bits * f.count or f.lsb < 0 or f.lsb > f.msb:
                raise InputError(
                    f"register field '{f.name}': bits {f.lsb}..{f.msb} do not fit in "
                    f"{f.count} register(s) of {self.value_bits} bits"
                )
            if f.address < 0 or f.address + f.count > (1 << self.address_bits):
                raise InputError(f"register field '{f.name}': address 0x{f.address:x} is out of the address space")

    def field(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        known = ", ".join(f.name for f in self.fields)
        raise UnknownRegister(f"unknown register field '{name}' (known: {known})")

    def names(self) -> list[str]:
        return [f.name for f in self.fields]


class RegisterFile:
    """Read/write named fields through a bus (read-modify-write for partial fields).

    ``buses``: every declared I2C device by its ``<i2c name>`` -- a field with ``bus=`` is read and
    written on that one, the others on ``bus`` (the sensor's). With the map's ``group_hold`` a
    value spanning several registers is written inside hold/release, and ``hold()`` groups
    several fields the same way (nested: one hold)."""

    def __init__(self, regmap: RegisterMap, bus, buses: dict | None = None):
        self.map = regmap
        self.bus = bus
        self.buses = dict(buses or {})
        self._holding = 0
        self._held: dict[int, int] = {}  # the sensor's registers written inside the open hold: the device
        #   still reads them old until the latch, so a read-modify-write of a second field in the same
        #   register must start from what was written, not from what the device reads

    def _bus(self, f: Field):
        if f.bus is None or f.bus not in self.buses:
            return self.bus
        return self.buses[f.bus]

    def _addresses(self, f: Field) -> list[int]:
        addrs = [f.address + i for i in range(f.count)]
        return addrs if self.map.endian == "big" else addrs[::-1]  # most significant first

    def _read1(self, bus, a: int) -> int:
        if self._holding and bus is self.bus and a in self._held:
            return self._held[a]
        return int(bus.read(a))

    def _read_value(self, f: Field) -> int:
        """A value spanning several registers, read whole: a frame boundary between two of its
        register reads would give half the old value and half the new (a torn read). A device that
        latches the value when one of its registers is read (``read_latch``) is read once, that
        register first; any other is read most significant first and its upper registers read
        again: unchanged, the value is whole (a change between the reads moved only the registers
        read after them); changed, it is read again."""
        bus, addrs, bits = self._bus(f), self._addresses(f), self.map.value_bits

        def combine(words):
            v = 0
            for w in words:
                v = (v << bits) | w
            return v

        if len(addrs) == 1 or self.map.read_latch == "msb":
            return combine([self._read1(bus, a) for a in addrs])
        if self.map.read_latch == "lsb":
            return combine(reversed([self._read1(bus, a) for a in reversed(addrs)]))
        for _ in range(READ_TRIES):
            words = [self._read1(bus, a) for a in addrs]
            if [self._read1(bus, a) for a in addrs[:-1]] == words[:-1]:
                return combine(words)
        raise HardwareError(f"{getattr(bus, 'name', 'registers')}: the {f.count} registers from 0x{f.address:x} "
                            f"changed during each of {READ_TRIES} reads: the value cannot be read whole (a device "
                            "that latches it on one register's read: declare <registers read_latch>)")

    @contextmanager
    def hold(self):
        """The sensor's group hold around the writes inside (nothing without ``group_hold``)."""
        gh = self.map.group_hold
        if gh is None or self._holding:
            self._holding += 1
            try:
                yield
            finally:
                self._holding -= 1
            return
        self.bus.write(gh[0], gh[1])
        self._holding, self._held = 1, {}
        self.bus.holding = True  # (held writes are verified after the frame boundary where they take effect)
        try:
            yield
        except BaseException:
            self._holding, self._held = 0, {}
            self.bus.holding = False
            try:  # release what was held; a write that failed inside says why (a failed release would hide it)
                self.bus.write(gh[0], gh[2])
            except Exception:
                pass
            raise
        self._holding, self._held = 0, {}
        self.bus.holding = False
        self.bus.write(gh[0], gh[2])  # release: the held registers take effect together

    def _write_value(self, f: Field, value: int) -> None:
        bits, bus = self.map.value_bits, self._bus(f)
        words = []
        for _ in range(f.count):
            words.append(value & ((1 << bits) - 1))
            value >>= bits
        held = self.map.group_hold is not None and f.count > 1 and bus is self.bus
        with (self.hold() if held else _nothing()):
            for a, w in zip(self._addresses(f), reversed(words)):
                bus.write(a, w)
                if self._holding and bus is self.bus:
                    self._held[a] = w

    def get_raw(self, name: str) -> int:
        f = self.map.field(name)
        if f.access == "wo":
            raise InputError(f"register field '{name}' is write-only and cannot be read")
        with _naming(name):
            return (self._read_value(f) & f.mask) >> f.lsb

    def set_raw(self, name: str, raw: int) -> None:
        f = self.map.field(name)
        if f.access == "ro":
            raise InputError(f"register field '{name}' is read-only and cannot be written")
        if raw < 0 or raw >= (1 << f.width):
            raise ValueOutOfRange(f"register field '{name}': raw value {raw} does not fit in {f.width} bits")
        full = f.width == f.count * self.map.value_bits
        with _naming(name):
            old = 0 if (full or f.access == "wo") else self._read_value(f)
            self._write_value(f, (old & ~f.mask) | (raw << f.lsb))

    def get(self, name: str) -> float:
        f = self.map.field(name)
        return f.to_physical(self.get_raw(name))

    def set(self, name: str, physical: float) -> None:
        f = self.map.field(name)
        self.set_raw(name, f.to_raw(physical))

    def set_many(self, values: dict[str, float], changed=None) -> dict:
        """Several fields as one change (a scan stage's settings): every value checked against its
        limits first, then all written inside one group hold when the map declares one -- they
        latch together at the next frame start, never some new and some old -- else one at a
        time, as before. Returns what was done (``write_record``) for ``changed`` (default: all)."""
        plain = type(self).set is RegisterFile.set  # (a subclass -- GenICam features -- checks its own way)
        for name, physical in values.items():  # nothing written when one cannot be
            f = self.map.field(name)
            if f.access == "ro":
                raise InputError(f"register field '{name}' is read-only and cannot be written")
            if plain:
                f.to_raw(physical)  # (its limits and its bits)
            else:
                f.check(physical)
        with (self.hold() if self.map.group_hold is not None and values else _nothing()):
            for name, physical in values.items():
                self.set(name, physical)
        return self.write_record(list(values) if changed is None else list(changed))

    def write_record(self, names) -> dict:
        """Whether a change of the fields ``names`` written by ``set_many`` takes effect at one
        frame start (``atomic``) and how, in one sentence (a stage's metadata)."""
        fields = [self.map.field(n) for n in names]
        gh = self.map.group_hold
        outside = [f.name for f in fields if self._bus(f) is not self.bus]
        rec = {"fields": [f.name for f in fields]}
        if gh is not None and not outside:
            return dict(rec, atomic=True, how=f"inside one group hold (register 0x{gh[0]:04x}): they take effect "
                        "together at the next frame start")
        if len(fields) <= 1 and all(f.count == 1 for f in fields):
            return dict(rec, atomic=True, how="one register: it takes effect at once")
        if gh is not None:
            return dict(rec, atomic=False, how=f"inside one group hold (register 0x{gh[0]:04x}) except "
                        f"{', '.join(outside)} on another device, which take(s) effect when written")
        return dict(rec, atomic=False, how="one register at a time: the register map declares no <group_hold>, so a "
                    "frame that starts between two writes carries some new settings and some old")

    def snapshot(self) -> dict[str, float]:
        """Every readable field's physical value (for run-directory provenance)."""
        return {f.name: self.get(f.name) for f in self.map.fields if f.access != "wo"}
