"""Build the ``Bench`` a system XML declares: the simulator, recorded data (``<replay>``), or real
I2C/USB/serial devices."""

from __future__ import annotations

from ares.errors import InputError
from ares.hardware.interfaces import Bench
from ares.rig.instruments import open_instrument
from ares.sim.from_system import sim_params


def build_bench(system, *, seed: int | None = None, faults: dict | None = None, uses: set | None = None) -> Bench:
    """The simulated bench when the system has ``<simulator>``, else the real devices.
    ``uses``: the instruments the scan needs ("light", "chamber"; None: every one) -- one
    it does not need may fail to open (not answer its identify command): the bench goes
    without it and says why in ``info["unavailable"]``."""
    if system.simulator is not None and system.simulator.wire:
        from ares.rig.wire import build_wire_bench

        return build_wire_bench(system, system.simulator.seed if seed is None else seed, faults, uses)
    if system.simulator is not None:
        from ares.sim import make_sim_bench

        bench = make_sim_bench(sim_params(system), system.simulator.seed if seed is None else seed, faults,
                               readout_s=system.timing.readout_s if system.simulator.paced else None)
        bench.info.setdefault("system", system.name)
        from ares.rig.spectral import attach_simulated

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
    return build_real_bench(system, uses)


def build_real_bench(system, uses: set | None = None) -> Bench:
    from ares.hardware.serial_instruments import SerialChamber, SerialLightSource
    from ares.hardware.usb import UsbFrameSource

    if not system.buses:
        raise InputError(f"system '{system.name}' declares no <buses><i2c> for the sensor registers")
    if system.usb_grabber is None:
        raise InputError(f"system '{system.name}' declares no <usb_grabber> frame source")
    from ares.rig.buses import open_buses, sensor_bus, verify_after_frames

    b, s = sensor_bus(system), system.sensor
    regs, bus, opened = open_buses(system)
    try:
        if b.readback != "image_row":  # an image-row sensor is connected once its frames flow
            bus.connect()
        g = system.usb_grabber
        frames = UsbFrameSource.open(g, (s.rows, s.cols), s.adc_bits, channels=s.adc_channels,
                                     interleave=s.adc_interleave)
        opened.append(frames)
        verify_after_frames(frames, opened)
        if b.readback == "image_row":
            from ares.hardware.i2c import ImageRowReadback

            enable = (lambda on: regs.set(b.readback_field, 1 if on else 0)) if b.readback_field else None
            bus.readback = ImageRowReadback(bus, frames, b.readback_row, b.readback_start, enable)
            bus.connect()
        unavailable = {}
        light = open_instrument("light", lambda: SerialLightSource.open(system.light_source), uses,
                                unavailable) if system.light_source else None
        opened.append(light)
        chamber = open_instrument("chamber", lambda: SerialChamber.open(system.chamber), uses,
                                  unavailable) if system.chamber else None
        opened.append(chamber)
        bench = Bench(regs, frames, light, chamber, {"system": system.name})
        if len(system.buses) > 1:
            bench.info["i2c_devices"] = [x.name for x in system.buses]
        if unavailable:
            bench.info["unavailable"] = unavailable
        from ares.rig.spectral import open_spectral

        open_spectral(bench, system, opened)
    except BaseException:
        for dev in opened:
            if dev is not None and hasattr(dev, "close"):
                dev.close()
        raise
    return bench

