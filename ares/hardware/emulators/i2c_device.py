"""An emulated I2C sensor that receives the ``i2c_msg`` transactions smbus2 sends.

``EmulatedSMBus`` stands in for ``smbus2.SMBus``: ``i2c_rdwr(*msgs)`` takes the very
message objects ``I2CRegisterBus`` builds. A write message is a register address
(``address_bits/8`` bytes, most significant first) followed by values (``value_bits/8``
bytes each, in the bus's byte order, auto-incrementing); a write of the address alone
followed by a read message returns values from there. The registers live in a
``RegisterBus`` (the simulator's ``SimRegisterBus``), so the simulated sensor sees every
write. A device at another address does not acknowledge.

Faults (``--sim-fault`` keys, N = 0-based transaction count): ``i2c_nack_at`` (NACK) and
``i2c_timeout_at`` (the bus times out), ``i2c_busy_at`` (another master holds the bus:
EBUSY), ``i2c_enxio_at`` (a NACK as the kernel's i2c-dev
reports it for an absent address, ENXIO), each for ``i2c_fault_count`` transactions in a row
(default 1: a retry succeeds); ``i2c_disconnect_at`` (the adapter is gone from then on, or
with ``i2c_gone_for=K`` for K transactions: a host that reconnects finds it again).
"""

from __future__ import annotations

import ctypes
import errno
from contextlib import contextmanager

FAULTS = ("i2c_nack_at", "i2c_enxio_at", "i2c_busy_at", "i2c_fault_count", "i2c_timeout_at", "i2c_disconnect_at",
          "i2c_gone_for")


class EmulatedSMBus:
    def __init__(self, device_address: int, registers, *, address_bits: int = 16, value_bits: int = 16,
                 value_endian: str = "big", faults: dict | None = None, readable: bool = True, clock=None,
                 speed_hz: int = 400000):
        self.device_address = device_address
        self.registers = registers  # .read(addr) / .write(addr, value)
        self.abytes, self.vbytes = address_bits // 8, value_bits // 8
        self.value_endian = value_endian
        self.readable = readable  # False: a sensor without I2C read (its reads NACK)
        self.faults = {k: int(v) for k, v in (faults or {}).items() if k in FAULTS}
        self.transactions = 0
        self.gone = False
        self._pointer = 0
        self.clock, self.speed_hz = clock, int(speed_hz)  # a transaction takes bus time on the bench's clock

    def _fault(self) -> None:
        n = self.transactions
        self.transactions += 1
        at = self.faults.get("i2c_disconnect_at")
        if self.gone or n == at:
            self.gone = True
            back = self.faults.get("i2c_gone_for")
            if not back or n < at + back:
                raise OSError(errno.ENODEV, "No such device")
            self.gone = False
        k = self.faults.get("i2c_fault_count", 1)
        at = self.faults.get("i2c_timeout_at")
        if at is not None and at <= n < at + k:
            raise OSError(errno.ETIMEDOUT, "Connection timed out")
        at = self.faults.get("i2c_nack_at")
        if at is not None and at <= n < at + k:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")
        at = self.faults.get("i2c_enxio_at")
        if at is not None and at <= n < at + k:
            raise OSError(errno.ENXIO, "No such device or address")
        at = self.faults.get("i2c_busy_at")
        if at is not None and at <= n < at + k:
            raise OSError(errno.EBUSY, "Device or resource busy")

    def i2c_rdwr(self, *msgs) -> None:
        self._fault()
        if self.clock is not None:  # start, address byte + data bytes (9 clocks each, with the ACK), stop
            self.clock.advance(sum(9 * (1 + m.len) + 2 for m in msgs) / self.speed_hz)
        for m in msgs:
            if m.addr != self.device_address:
                raise OSError(errno.EREMOTEIO, "Remote I/O error")
            if m.flags & 1:  # I2C_M_RD
                if not self.readable:
                    raise OSError(errno.EREMOTEIO, "Remote I/O error")
                out = bytearray()
                while len(out) < m.len:
                    out += int(self.registers.read(self._pointer)).to_bytes(self.vbytes, self.value_endian)
                    self._pointer += 1
                ctypes.memmove(m.buf, bytes(out[:m.len]), m.len)
            else:
                data = bytes(m)
                if len(data) < self.abytes:
                    raise OSError(errno.EREMOTEIO, "Remote I/O error")
                self._pointer = int.from_bytes(data[:self.abytes], "big")
                values = data[self.abytes:]
                if len(values) % self.vbytes:
                    raise OSError(errno.EREMOTEIO, "Remote I/O error")
                for k in range(0, len(values), self.vbytes):
                    try:
                        self.registers.write(self._pointer, int.from_bytes(values[k:k + self.vbytes],
                                                                           self.value_endian))
                    except Exception:  # a register the device refuses: no acknowledge
                        raise OSError(errno.EREMOTEIO, "Remote I/O error") from None
                    self._pointer += 1

    def close(self) -> None:
        pass


class KernelI2C:
    """The kernel side of ``/dev/i2c-N`` for the real smbus2 code: ``os.open`` of the device
    node and the ioctls smbus2 issues (``I2C_FUNCS``, ``I2C_RDWR``), served by one
    ``EmulatedSMBus`` per bus number. ``with KernelI2C({1: emu}).installed():`` -- everything
    above the kernel call (message structs, the ioctl data) is smbus2's own."""

    I2C_FUNCS, I2C_RDWR = 0x0705, 0x0707
    _FD0 = 1 << 20  # file descriptors no real file has

    def __init__(self, adapters: dict):
        self.adapters = dict(adapters)
        self.opened: list[str] = []

    def _open(self, real, path, flags, *args):
        path = str(path)
        if not path.startswith("/dev/i2c-"):
            return real.open(path, flags, *args)
        bus = int(path.rsplit("-", 1)[1])
        if bus not in self.adapters:
            raise FileNotFoundError(errno.ENOENT, "No such file or directory", path)
        self.opened.append(path)
        return self._FD0 + bus

    def ioctl(self, fd, request, arg, *rest):
        emu = self.adapters.get(fd - self._FD0)
        if emu is None:
            raise OSError(errno.EBADF, "Bad file descriptor")
        if request == self.I2C_FUNCS:
            arg.value = 0x1  # I2C_FUNC_I2C: combined transactions
        elif request == self.I2C_RDWR:
            emu.i2c_rdwr(*(arg.msgs[k] for k in range(arg.nmsgs)))
        else:
            raise OSError(errno.ENOTTY, "Inappropriate ioctl for device")
        return 0

    @contextmanager
    def installed(self):
        import os

        import smbus2.smbus2 as lib

        kernel = self

        class _Os:  # os for smbus2: the device nodes are ours, everything else is the real os
            def __getattr__(self, name):
                return getattr(os, name)

            def open(self, path, flags, *args):
                return kernel._open(os, path, flags, *args)

            def close(self, fd):
                if fd < kernel._FD0:
                    os.close(fd)

        saved = lib.os, lib.ioctl
        lib.os, lib.ioctl = _Os(), self.ioctl
        try:
            yield self
        finally:
            lib.os, lib.ioctl = saved
