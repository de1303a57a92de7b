"""The I2C devices a system XML declares (``<buses><i2c>``, several allowed), opened: the
sensor's -- the ``<i2c>`` its ``<registers bus>`` names, else the first -- and every other, each
on its own adapter (``/dev/i2c-<bus>``) and address; register fields with ``bus=NAME`` are read
and written on that device (``RegisterFile.buses``)."""

from __future__ import annotations

from ares.hardware.i2c import open_i2c_bus
from ares.hardware.registers import RegisterFile


def sensor_bus(system):
    """The ``<i2c>`` declaration the sensor's registers are on."""
    name = system.registers.bus
    return next((b for b in system.buses if b.name == name), system.buses[0]) if name else system.buses[0]


def open_buses(system, smbus_for=None):
    """(``RegisterFile`` over every declared device, the sensor's bus, every bus opened). The
    sensor's is not connected yet (an image-row sensor is connected once frames flow); the
    others are (chip ID and ``<init>``). ``smbus_for(i2c) -> adapter``: an emulated one (tests,
    the wire bench), None: the kernel's."""
    main = sensor_bus(system)
    opened, buses = [], {}
    try:
        for b in system.buses:
            bus = open_i2c_bus(b, system.registers, smbus_for(b) if smbus_for else None, sensor=b is main)
            opened.append(bus)
            buses[b.name] = bus
            if b is not main:
                bus.connect()
    except BaseException:
        for bus in opened:
            bus.close()
        raise
    return RegisterFile(system.registers, buses[main.name], buses), buses[main.name], opened


def verify_after_frames(frames, buses) -> None:
    """Double-buffered registers (``buffered="frame"``) and writes inside a group hold are read
    back once a frame has arrived after them: the frame source calls each verifying bus's
    ``verify_pending`` per frame."""
    hooks = [b.verify_pending for b in buses if getattr(b, "verify", False)]  # (nothing pending: nothing read)
    if hooks:
        frames.after_frame = list(getattr(frames, "after_frame", [])) + hooks
