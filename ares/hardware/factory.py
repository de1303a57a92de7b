"""Build the ``Bench`` a system XML declares: the simulator, recorded data (``<replay>``), or real
I2C/USB/serial devices."""

from __future__ import annotations

from ares.errors import InputError
from ares.hardware.interfaces import Bench
from ares.hardware.registers import RegisterFile


def _line_of(path, name: str) -> int | None:
    """Line of ``<param name="name"`` in a system file (for error messages)."""
    import re

    try:
        text = open(path, encoding="utf-8", errors="replace").read()
    except OSError:
        return None
    m = re.search(r'<param\s+[^>]*name\s*=\s*["\']' + re.escape(name) + r'["\']', text)
    if m is None:
        m = re.search(r"<simulator\b", text)
    return text.count("\n", 0, m.start()) + 1 if m else None


def sim_params(system):
    """``SensorParams`` from the system's ``<simulator>`` block (array size and ADC bits
    from ``<sensor>``); errors name the system file and the parameter's line."""
    import re

    from ares.sim import SensorParams

    from ares.sim.regmap import SIM_REGISTER_MAP

    d = dict(system.simulator.params)
    src = system.source or system.name
    if system.registers != SIM_REGISTER_MAP:
        raise InputError(f"{src}:{_line_of(src, '')}: a <simulator> system must declare the simulated sensor's "
                         "register map (copy <registers> from protocols/sim_sensor.xml)")
    for key, want in (("rows", system.sensor.rows), ("cols", system.sensor.cols), ("adc_bits", system.sensor.adc_bits)):
        if key in d and d[key] != want:
            line = _line_of(src, key)
            raise InputError(f"{src}:{line}: simulator parameter '{key}' = {d[key]} contradicts the sensor's {want}")
        d[key] = want
    if system.sensor.cfa != "mono":
        d.setdefault("cfa", system.sensor.cfa)
    try:
        return SensorParams.from_dict(d)
    except (InputError, TypeError) as exc:
        names = [n for n in re.findall(r"'([A-Za-z_][A-Za-z0-9_]*)'", str(exc)) if n in d]
        line = _line_of(src, names[0]) if names else _line_of(src, "")
        raise InputError(f"{src}:{line}: <simulator>: {exc}") from None


def build_bench(system, *, seed: int | None = None, faults: dict | None = None) -> Bench:
    """The simulated bench when the system has ``<simulator>``, else the real devices."""
    if system.simulator is not None and system.simulator.wire:
        from ares.hardware.wire_bench import build_wire_bench

        return build_wire_bench(system, system.simulator.seed if seed is None else seed, faults)
    if system.simulator is not None:
        from ares.sim import make_sim_bench

        bench = make_sim_bench(sim_params(system), system.simulator.seed if seed is None else seed, faults,
                               readout_s=system.timing.readout_s if system.simulator.paced else None)
        bench.info.setdefault("system", system.name)
        from ares.hardware.spectral_bench import attach_simulated

        try:
            attach_simulated(bench, system, bench, seed=system.simulator.seed if seed is None else seed)
        except BaseException:
            bench.close()
            raise
        return bench
    if faults:
        raise InputError("fault injection is only available on the simulated bench")
    if system.genicam is not None:
        from ares.hardware.genicam import build_genicam_bench

        return build_genicam_bench(system)
    if getattr(system, "replay", None) is not None:
        from ares.hardware.replay import build_replay_bench

        return build_replay_bench(system)
    return build_real_bench(system)


def build_real_bench(system) -> Bench:
    from ares.hardware.i2c import open_i2c_bus
    from ares.hardware.serial_instruments import SerialChamber, SerialLightSource
    from ares.hardware.usb import UsbFrameSource

    if not system.buses:
        raise InputError(f"system '{system.name}' declares no <buses><i2c> for the sensor registers")
    if system.usb_grabber is None:
        raise InputError(f"system '{system.name}' declares no <usb_grabber> frame source")
    b, s = system.buses[0], system.sensor
    bus = open_i2c_bus(b, system.registers)
    opened = [bus]
    try:
        if b.readback != "image_row":  # an image-row sensor is connected once its frames flow
            bus.connect()
        regs = RegisterFile(system.registers, bus)
        g = system.usb_grabber
        frames = UsbFrameSource.open(g, (s.rows, s.cols), s.adc_bits, channels=s.adc_channels,
                                     interleave=s.adc_interleave)
        opened.append(frames)
        if b.readback == "image_row":
            from ares.hardware.i2c import ImageRowReadback

            enable = (lambda on: regs.set(b.readback_field, 1 if on else 0)) if b.readback_field else None
            bus.readback = ImageRowReadback(bus, frames, b.readback_row, b.readback_start, enable)
            bus.connect()
        light = SerialLightSource.open(system.light_source) if system.light_source else None
        opened.append(light)
        chamber = SerialChamber.open(system.chamber) if system.chamber else None
        opened.append(chamber)
        bench = Bench(regs, frames, light, chamber, {"system": system.name})
        from ares.hardware.spectral_bench import open_spectral

        open_spectral(bench, system, opened)
    except BaseException:
        for dev in opened:
            if dev is not None and hasattr(dev, "close"):
                dev.close()
        raise
    return bench
