"""Sensor registers over I2C (smbus2): a ``RegisterBus`` for ``RegisterFile``.

A register access is one combined transaction: write the register address
(``address_bits/8`` bytes, most significant first), then read or write
``value_bits/8`` bytes (most significant first) -- the usual 16-bit-address CIS
convention. Bus errors become ``DeviceGone`` naming the bus, device and register.
"""

from __future__ import annotations

from ares.errors import DeviceGone, ValueOutOfRange


class I2CRegisterBus:
    def __init__(self, bus: int, address: int, address_bits: int = 16, value_bits: int = 8, *,
                 name: str = "i2c", smbus=None):
        self.name = name
        self.bus_number, self.address = bus, address
        self.abytes, self.vbytes = address_bits // 8, value_bits // 8
        self.value_bits, self.address_bits = value_bits, address_bits
        if smbus is None:
            try:
                from smbus2 import SMBus

                smbus = SMBus(bus)
            except (OSError, FileNotFoundError) as exc:
                raise DeviceGone(f"I2C bus {bus} ('{name}'): cannot open /dev/i2c-{bus} ({exc.strerror or exc})") from None
        self.smbus = smbus

    def _where(self, reg: int) -> str:
        return f"I2C device 0x{self.address:02x} on bus {self.bus_number} ('{self.name}'), register 0x{reg:0{2 * self.abytes}x}"

    def _check(self, reg: int) -> None:
        if not 0 <= reg < (1 << self.address_bits):
            raise ValueOutOfRange(f"{self._where(0)}: register address 0x{reg:x} is outside the address space")

    def read(self, address: int) -> int:
        from smbus2 import i2c_msg

        self._check(address)
        w = i2c_msg.write(self.address, address.to_bytes(self.abytes, "big"))
        r = i2c_msg.read(self.address, self.vbytes)
        try:
            self.smbus.i2c_rdwr(w, r)
        except OSError as exc:
            raise DeviceGone(f"{self._where(address)}: no answer on read ({exc.strerror or exc})") from None
        return int.from_bytes(bytes(r), "big")

    def write(self, address: int, value: int) -> None:
        from smbus2 import i2c_msg

        self._check(address)
        if not 0 <= value < (1 << self.value_bits):
            raise ValueOutOfRange(f"{self._where(address)}: value {value} does not fit in {self.value_bits} bits")
        msg = i2c_msg.write(self.address, address.to_bytes(self.abytes, "big") + value.to_bytes(self.vbytes, "big"))
        try:
            self.smbus.i2c_rdwr(msg)
        except OSError as exc:
            raise DeviceGone(f"{self._where(address)}: no answer on write ({exc.strerror or exc})") from None

    def close(self) -> None:
        close = getattr(self.smbus, "close", None)
        if close:
            close()
