"""Build the ``Bench`` a system XML declares: the simulator, or real I2C/USB/serial devices."""

from __future__ import annotations

from ares.errors import InputError
from ares.hardware.interfaces import Bench
from ares.hardware.registers import RegisterFile


def sim_params(system):
    """``SensorParams`` from the system's ``<simulator>`` block (array size from ``<sensor>``)."""
    from ares.sim import SensorParams

    d = dict(system.simulator.params)
    d.setdefault("rows", system.sensor.rows)
    d.setdefault("cols", system.sensor.cols)
    d.setdefault("adc_bits", system.sensor.adc_bits)
    if system.sensor.cfa != "mono":
        d.setdefault("cfa", system.sensor.cfa)
    src = system.source or system.name
    try:
        return SensorParams.from_dict(d)
    except InputError as exc:
        raise InputError(f"{src}: <simulator>: {exc}") from None
    except TypeError as exc:
        raise InputError(f"{src}: <simulator>: {exc}") from None


def build_bench(system, *, seed: int | None = None, faults: dict | None = None) -> Bench:
    """The simulated bench when the system has ``<simulator>``, else the real devices."""
    if system.simulator is not None:
        from ares.sim import make_sim_bench

        bench = make_sim_bench(sim_params(system), system.simulator.seed if seed is None else seed, faults)
        bench.info.setdefault("system", system.name)
        return bench
    if faults:
        raise InputError("fault injection is only available on the simulated bench")
    return build_real_bench(system)


def build_real_bench(system) -> Bench:
    from ares.hardware.i2c import I2CRegisterBus
    from ares.hardware.serial_instruments import SerialChamber, SerialLightSource
    from ares.hardware.usb import UsbFrameSource

    if not system.buses:
        raise InputError(f"system '{system.name}' declares no <buses><i2c> for the sensor registers")
    if system.usb_grabber is None:
        raise InputError(f"system '{system.name}' declares no <usb_grabber> frame source")
    b = system.buses[0]
    bus = I2CRegisterBus(b.bus, b.address, system.registers.address_bits, system.registers.value_bits, name=b.name)
    opened = [bus]
    try:
        regs = RegisterFile(system.registers, bus)
        g = system.usb_grabber
        frames = UsbFrameSource.open(g, (system.sensor.rows, system.sensor.cols), system.sensor.adc_bits)
        opened.append(frames)
        light = SerialLightSource.open(system.light_source) if system.light_source else None
        opened.append(light)
        chamber = SerialChamber.open(system.chamber) if system.chamber else None
    except BaseException:
        for dev in opened:
            if dev is not None and hasattr(dev, "close"):
                dev.close()
        raise
    return Bench(regs, frames, light, chamber, {"system": system.name})
