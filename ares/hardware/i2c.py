"""Sensor registers over I2C (smbus2 ``i2c_rdwr``): a ``RegisterBus`` for ``RegisterFile``.

One register access is one combined transaction: write the register address
(``address_bits/8`` bytes, most significant first), then read or write ``value_bits/8``
bytes in the bus's ``value_endian`` byte order -- the usual 8/16-bit-address CIS
convention. A NACK (the kernel's ENXIO or EREMOTEIO: a sensor busy or still powering up) or
a timeout is retried ``retries`` times (the XML's ``<i2c retries>``) after a pause that
doubles from ``BACKOFF_S``; then one ``DeviceGone`` names bus, device and register
(``RegisterFile`` adds the field). An adapter that is gone (ENODEV, ENOENT, EBADF) is not
retried.
With ``verify`` every write is read back and compared, except registers declared
``volatile`` (self-clearing triggers, status bits: the device changes them).

``connect()`` (at open and after a reconnect): the adapter's clock where the kernel shows it
(device tree ``clock-frequency`` under sysfs) must not exceed the declared ``speed_hz`` (the
kernel sets the bus speed; user space cannot); the chip-ID register must read the declared
value (a wrong or absent chip is refused before anything is written to it); then the
``<init>`` sequence: power-up writes (not verified: resets clear themselves) and waits.

Sensors without I2C read (``readback="image_row"``): reads come from an image row the
sensor fills with its registers (``ImageRowReadback``).
"""

from __future__ import annotations

import errno
import time

from ares.errors import DeviceGone, HardwareError, ValueOutOfRange
from ares.hardware.registers import latching_address

_GONE = {errno.ENODEV, errno.ENOENT, errno.EBADF}  # the adapter itself; ENXIO is a NACK (retried)
_NACK = {errno.ENXIO, errno.EREMOTEIO}  # no acknowledge (Documentation/i2c/fault-codes)
_BUSY = {errno.EBUSY, errno.EAGAIN}  # the bus busy too long / arbitration lost: another master
BACKOFF_S = 0.001  # the first pause before a retry, doubled each attempt


class I2CRegisterBus:
    def __init__(self, bus: int, address: int, address_bits: int = 16, value_bits: int = 8, *,
                 name: str = "i2c", smbus=None, retries: int = 2, verify: bool = False, value_endian: str = "big",
                 sleep=time.sleep, volatile=frozenset(), speed_hz: int | None = None, chip_id=None, init=(),
                 sysfs: str = "/sys/bus/i2c/devices", backoff_s: float = BACKOFF_S, shadow=None,
                 deferred=frozenset(), latch_via=None):
        self.name = name
        self.bus_number, self.address = bus, address
        self.abytes, self.vbytes = address_bits // 8, value_bits // 8
        self.value_bits, self.address_bits = value_bits, address_bits
        self.retries, self.verify, self.value_endian = int(retries), bool(verify), value_endian
        self._sleep = sleep
        self.backoff_s = float(backoff_s)  # the busy window (<i2c backoff_ms>): the first pause before a retry
        self.volatile = frozenset(volatile)  # register addresses not verified by read-back
        # double-buffered registers: a write lands in a pending (shadow) register and takes effect at
        # the next frame boundary; verified at the shadow address, or after a frame has arrived
        self.shadow = dict(shadow or {})  # address -> the address its pending value reads back at
        self.deferred = frozenset(deferred)  # addresses verified after the frame boundary (verify_pending)
        self.pending: dict[int, int] = {}  # written, not yet verified (the frame boundary has not passed)
        self._frames_seen: dict[int, int] = {}  # pending address -> frames arrived since its write
        # a device that latches a multi-register value when one of its registers is read (<registers
        # read_latch>) answers the others from that latch: a read-back reads the latching one first
        self.latch_via = dict(latch_via or {})  # address -> the register whose read latches it
        self.holding = False  # inside the sensor's group hold: writes take effect at the frame after release
        self.speed_hz, self.chip_id, self.init, self.sysfs = speed_hz, chip_id, tuple(init), sysfs
        self.adapter_hz: int | None = None  # the adapter's clock, when the kernel shows it
        self.chip_id_read: int | None = None  # what the chip-ID register answered at connect
        self.readback = None  # ImageRowReadback for sensors without I2C read
        self.retried = 0  # transactions that needed a retry (a flaky bus shows here)
        # link statistics (ares.hardware.link_stats): transactions attempted, and the retries
        # after a NACK (ENXIO/EREMOTEIO), a busy bus (EBUSY/EAGAIN) and anything else (timeouts)
        self.transactions = self.nack_retries = self.busy_retries = self.other_retries = 0
        self._given = smbus  # an emulated adapter (tests) is reopened as itself
        self.smbus = smbus if smbus is not None else self._open()

    def _open(self):
        if self._given is not None:
            return self._given
        try:
            from smbus2 import SMBus

            return SMBus(self.bus_number)
        except (OSError, FileNotFoundError) as exc:
            raise DeviceGone(f"I2C bus {self.bus_number} ('{self.name}'): cannot open /dev/i2c-{self.bus_number} "
                             f"({exc.strerror or exc})", "registers") from None

    def reconnect(self) -> None:
        """Open the adapter again and address the device once (``DeviceGone`` while it is away)."""
        from smbus2 import i2c_msg

        if self._given is None:
            self.close()
        self.smbus = self._open()
        self._transfer(0, "reconnect", i2c_msg.write(self.address, bytes(self.abytes)))  # set the pointer: an ACK
        self.connect()  # a replugged sensor powered up again: its init again

    def connect(self) -> None:
        """Speed check, chip-ID check and the ``<init>`` sequence (module docstring)."""
        import os

        path = os.path.join(self.sysfs, f"i2c-{self.bus_number}", "of_node", "clock-frequency")
        self.adapter_hz = None
        if self._given is None:  # a kernel adapter (an emulated one has no sysfs node)
            try:
                with open(path, "rb") as fh:
                    self.adapter_hz = int.from_bytes(fh.read(4), "big")
            except OSError:  # no device tree node (x86, USB adapters): the speed cannot be read
                pass
        if self.speed_hz and self.adapter_hz and self.adapter_hz > self.speed_hz:
            raise HardwareError(f"I2C bus {self.bus_number} ('{self.name}') runs at {self.adapter_hz} Hz (its "
                                f"clock-frequency) but the system XML declares speed_hz={self.speed_hz} for "
                                f"device 0x{self.address:02x}: slow the adapter down in the device tree")
        if self.chip_id is not None:
            reg, want = self.chip_id
            got = self.read(reg)
            if got != want:
                raise HardwareError(f"{self._where(reg)}: chip ID reads 0x{got:x} but the system XML expects "
                                    f"0x{want:x} (a different sensor, or none, at this address)")
            self.chip_id_read = got
        for kind, a, v in self.init:
            if kind == "wait":
                self._sleep(a)
            else:
                self.write(a, v, verify=False)

    def _where(self, reg: int) -> str:
        return (f"I2C device 0x{self.address:02x} on bus {self.bus_number} ('{self.name}'), "
                f"register 0x{reg:0{2 * self.abytes}x}")

    def _check(self, reg: int) -> None:
        if not 0 <= reg < (1 << self.address_bits):
            raise ValueOutOfRange(f"{self._where(0)}: register address 0x{reg:x} is outside the address space")

    def _transfer(self, reg: int, what: str, *msgs) -> None:
        for attempt in range(self.retries + 1):
            self.transactions += 1
            try:
                self.smbus.i2c_rdwr(*msgs)
                if attempt:
                    self.retried += 1
                return
            except OSError as exc:
                if exc.errno in _GONE:
                    raise DeviceGone(f"{self._where(reg)}: device gone on {what} ({exc.strerror or exc})",
                                     "registers") from None
                last = exc
                if attempt < self.retries:
                    if exc.errno in _NACK:
                        self.nack_retries += 1
                    elif exc.errno in _BUSY:
                        self.busy_retries += 1
                    else:
                        self.other_retries += 1
                    self._sleep(self.backoff_s * (1 << attempt))
        kind = {errno.ETIMEDOUT: "timeout", errno.EBUSY: "bus busy", errno.EAGAIN: "bus busy (arbitration lost)"}.get(
            last.errno, "no acknowledge")
        raise DeviceGone(f"{self._where(reg)}: {kind} on {what} after {self.retries + 1} attempt(s) "
                         f"({last.strerror or last})", "registers")

    def read(self, address: int) -> int:
        if self.readback is not None:
            return self.readback.read(address)
        from smbus2 import i2c_msg

        self._check(address)
        w = i2c_msg.write(self.address, address.to_bytes(self.abytes, "big"))
        r = i2c_msg.read(self.address, self.vbytes)
        self._transfer(address, "read", w, r)
        return int.from_bytes(bytes(r), self.value_endian)

    def write(self, address: int, value: int, verify: bool | None = None) -> None:
        from smbus2 import i2c_msg

        self._check(address)
        if not 0 <= value < (1 << self.value_bits):
            raise ValueOutOfRange(f"{self._where(address)}: value {value} does not fit in {self.value_bits} bits")
        msg = i2c_msg.write(self.address, address.to_bytes(self.abytes, "big")
                            + value.to_bytes(self.vbytes, self.value_endian))
        self._transfer(address, "write", msg)
        if self.readback is not None:
            self.readback.written(address, value)
        elif (self.verify if verify is None else verify) and address not in self.volatile:
            if address in self.deferred or self.holding:  # takes effect at the frame boundary: read back after it
                self.pending[address] = value
                self._frames_seen[address] = 0
                return
            at = self.shadow.get(address, address)
            got = self._read_back(at)
            if got != value:
                where = "" if at == address else f" at its shadow register 0x{at:0{2 * self.abytes}x}"
                raise HardwareError(f"{self._where(address)}: wrote 0x{value:x} but read back 0x{got:x}{where} "
                                    "(write-verify)")

    def _read_back(self, address: int) -> int:
        if address in self.latch_via:  # (its latch holds what the last read of the latching register copied)
            self.read(self.latch_via[address])
        return self.read(address)

    def verify_pending(self) -> None:
        """A frame has arrived since the writes to double-buffered registers (``buffered="frame"``) or
        inside a group hold: read them back now. On a streaming sensor that frame may have started
        before the writes (the frame in flight) and the next one, whose start latches them, may
        start only after the vertical blanking -- after this read: a value not yet taken is read
        back again after the next frame, and only then called a failed write."""
        pending, self.pending = self.pending, {}
        for address, value in pending.items():
            got = self._read_back(address)
            seen = self._frames_seen.pop(address, 1) + 1
            if got != value and seen < 2:
                self.pending[address], self._frames_seen[address] = value, seen
            elif got != value:
                raise HardwareError(f"{self._where(address)}: wrote 0x{value:x} but read back 0x{got:x} after the "
                                    "frame boundary where a double-buffered register takes effect, two frames after "
                                    "the write (write-verify)")

    def link_counters(self) -> dict:
        """The link statistics since open (``ares.hardware.link_stats``)."""
        return {"transactions": self.transactions, "nack_retries": self.nack_retries,
                "busy_retries": self.busy_retries, "timeout_retries": self.other_retries}

    def identity(self) -> dict:
        """Bus, address and the chip ID the sensor answered at connect (when one is declared)."""
        out = {"interface": "I2C", "bus": self.bus_number, "address": f"0x{self.address:02x}"}
        if self.chip_id_read is not None:
            out["chip_id"] = f"0x{self.chip_id_read:x}"
        if self.adapter_hz:
            out["adapter_hz"] = self.adapter_hz
        return out

    def close(self) -> None:
        close = getattr(self.smbus, "close", None)
        if close:
            close()


def open_i2c_bus(b, regmap, smbus=None, sensor: bool = True) -> I2CRegisterBus:
    """A device's bus from its ``<i2c>`` declaration and the register map's fields on it (those
    with ``bus=`` its name; ``sensor``: also those without), not yet connected (``connect()``):
    volatile fields' addresses are not verified, double-buffered ones at their shadow address
    or after the frame boundary."""
    mine = [f for f in regmap.fields if f.bus == b.name or (sensor and f.bus is None)]
    volatile = {f.address + k for f in mine if f.volatile for k in range(f.count)}
    shadow = {f.address + k: f.shadow + k for f in mine if f.buffered == "shadow" for k in range(f.count)}
    deferred = {f.address + k for f in mine if f.buffered == "frame" for k in range(f.count)}
    latch_via = {}
    for f in mine:
        first = latching_address(f, regmap.endian, regmap.read_latch)
        if first is not None:
            latch_via.update({f.address + k: first for k in range(f.count) if f.address + k != first})
    return I2CRegisterBus(b.bus, b.address, regmap.address_bits, regmap.value_bits, name=b.name, smbus=smbus,
                          retries=b.retries, verify=b.verify, value_endian=b.value_endian, volatile=volatile,
                          speed_hz=b.speed_hz, chip_id=b.chip_id, init=b.init,
                          backoff_s=getattr(b, "backoff_ms", 1.0) / 1000.0, shadow=shadow, deferred=deferred,
                          latch_via=latch_via)


class ImageRowReadback:
    """Register reads for a sensor that cannot be read over I2C: set ``field`` to 1, grab one
    frame, and take the registers from image row ``row`` -- pixel k holds byte k of the
    register space from ``start`` (each register ``value_bits/8`` bytes, most significant
    first). The frame is cached until the next register write."""

    def __init__(self, bus: I2CRegisterBus, frames, row: int, start: int, enable=None):
        self.bus, self.frames, self.row, self.start = bus, frames, int(row), int(start)
        self.enable = enable  # callable(bool) switching the sensor's readback mode (a register write)
        self._row = None
        self.frames_used = 0

        self._shadow: dict[int, int] = {}  # what was written (read-modify-write while switching the mode)
        self._busy = False

    def written(self, address: int, value: int) -> None:
        self._shadow[address] = value
        if not self._busy:
            self._row = None

    def _fetch(self):
        self._busy = True
        try:
            if self.enable is not None:
                self.enable(True)
            try:
                frame = next(iter(self.frames.grab(1)))
            finally:
                if self.enable is not None:
                    self.enable(False)
        finally:
            self._busy = False
        self._row = [int(v) for v in frame.data[self.row]]
        self.frames_used += 1

    def read(self, address: int) -> int:
        if self._busy:  # switching the readback mode: the last value written
            return self._shadow.get(address, 0)
        if self._row is None:
            self._fetch()
        k = (address - self.start) * self.bus.vbytes
        if not 0 <= k <= len(self._row) - self.bus.vbytes:
            raise ValueOutOfRange(f"{self.bus._where(address)}: outside the registers image row {self.row} carries "
                                  f"(0x{self.start:x} .. 0x{self.start + len(self._row) // self.bus.vbytes - 1:x})")
        v = 0
        for b in self._row[k:k + self.bus.vbytes]:
            v = (v << 8) | (b & 0xFF)
        return v
