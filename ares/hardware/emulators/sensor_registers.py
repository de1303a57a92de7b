"""A sensor's register file as its datasheet describes it, in front of the simulator's
registers: group hold and double-buffered (shadowed) registers.

* Group hold (``<registers><group_hold register hold release>``): writing ``hold`` to the hold
  register holds every write that follows; writing ``release`` lets them all take effect
  together at the next frame boundary -- a value spanning several registers is never latched
  half old, half new.
* Double-buffered registers (``<field buffered="shadow|frame" shadow=>``): a write lands in
  the pending register and takes effect at the next frame boundary; until then the register
  reads its active (old) value, and its ``shadow`` address, when it has one, reads the
  pending value.
* Every other register takes effect at once -- so a multi-register value written without the
  hold is torn when a frame boundary falls between its registers.
* Reads return the active values as they are at each register's read: a frame boundary (a
  latch) between the reads of a multi-register value's registers gives half the old value
  and half the new (a torn read). ``read_latch`` ("msb"/"lsb", default the map's
  ``<registers read_latch>``): reading that register of a value copies the value's other
  registers into a latch they are then read from (until that register is read again) -- the
  16-bit timer of a microcontroller (low byte first) or a sensor's shadowed readout (high byte
  first) -- so a host that reads it first reads the value whole.

Frame boundaries: ``frame_boundary()`` (the grabber calls it as each frame starts); on a
free-running sensor with ``frame_period_s`` also at every multiple of it on ``clock`` (the
bench's), checked at every register access -- an I2C transaction takes bus time
(``EmulatedSMBus(clock=...)``), so a boundary can fall between two of them. ``exposed``: the
multi-register values each frame was exposed with (field name -> raw value), the device's own
record of what its frames saw.
"""

from __future__ import annotations

from ares.hardware.registers import latching_address


class SensorRegisters:
    def __init__(self, regmap, inner, *, clock=None, frame_period_s: float | None = None, read_latch="map"):
        self.map, self.inner = regmap, inner
        latch = regmap.read_latch if read_latch == "map" else read_latch
        self.latch_on: dict[int, list[int]] = {}  # the register whose read latches -> the value's others
        for f in regmap.fields:
            first = latching_address(f, regmap.endian, latch) if f.bus is None else None
            if first is not None:
                self.latch_on[first] = [f.address + k for k in range(f.count) if f.address + k != first]
        self.latch: dict[int, int] = {}  # what the last latching read copied
        self.start_owed = False  # a streaming sensor with vertical blanking: the next frame starts later
        self.name = getattr(inner, "name", "sensor")
        gh = regmap.group_hold
        self.hold_register, self.hold_value, self.release_value = gh if gh is not None else (None, None, None)
        self.buffered = {f.address + k for f in regmap.fields if f.buffered for k in range(f.count)}
        self.shadows = {f.shadow + k: f.address + k for f in regmap.fields
                        if f.buffered == "shadow" and f.shadow is not None for k in range(f.count)}
        self.values = [f for f in regmap.fields if f.count > 1 and f.bus is None]
        self.holding = False
        self.held: dict[int, int] = {}
        self.pending: dict[int, int] = {}
        self.exposed: list[dict] = []
        self.clock, self.period = clock, frame_period_s
        self._next = clock.now() + frame_period_s if clock is not None and frame_period_s else None

    def _tick(self) -> None:
        if self._next is None:
            return
        while self.clock.now() >= self._next:
            self.frame_boundary()
            self._next += self.period

    def owe_start(self) -> None:
        """A frame was read out; the next starts after the vertical blanking -- later than a host's
        read-back right after the frame, sooner than its next register writes (``start_if_owed``)."""
        self.start_owed = True

    def start_if_owed(self) -> None:
        if self.start_owed:
            self.start_owed = False
            self.frame_boundary()

    def frame_boundary(self) -> None:
        """A frame starts: pending registers take effect; the frame is exposed with what is active."""
        for a, v in self.pending.items():
            self.inner.write(a, v)
        self.pending = {}
        self.exposed.append({f.name: self._active(f) for f in self.values})

    def _active(self, f) -> int:
        v = 0
        addrs = [f.address + k for k in range(f.count)]
        for a in addrs if self.map.endian == "big" else addrs[::-1]:
            v = (v << self.map.value_bits) | int(self.inner.read(a))
        return v

    def read(self, address: int) -> int:
        self._tick()
        if address in self.shadows:  # the pending value (the active one when nothing is pending)
            src = self.shadows[address]
            return self.pending.get(src, self.held.get(src, self.inner.read(src)))
        if address == self.hold_register:
            return self.hold_value if self.holding else self.release_value
        if address in self.latch_on:  # the latching register: the value's others are copied now
            self.latch.update({a: self.inner.read(a) for a in self.latch_on[address]})
        elif address in self.latch:
            return self.latch[address]
        return self.inner.read(address)

    def write(self, address: int, value: int) -> None:
        self._tick()
        self.start_if_owed()  # (the host took longer than the blanking to write: the frame started first)
        if address == self.hold_register:
            if value == self.hold_value:
                self.holding = True
            elif value == self.release_value and self.holding:
                self.holding = False
                self.pending.update(self.held)  # all together, at the next frame boundary
                self.held = {}
            return
        if self.holding:
            self.inner.read(address)  # (an address the sensor does not have is refused now, not later)
            self.held[address] = value
        elif address in self.buffered:
            self.inner.read(address)
            self.pending[address] = value
        else:
            self.inner.write(address, value)

    def close(self) -> None:
        pass


def device_registers(regmap, inner, **kw):
    """The sensor's registers with the behaviours its map declares (group hold, double
    buffering, a read latch), or ``inner`` itself when it declares none."""
    if regmap.group_hold is None and regmap.read_latch is None and not any(f.buffered for f in regmap.fields):
        return inner
    return SensorRegisters(regmap, inner, **kw)
