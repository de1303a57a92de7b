"""The simulated sensor behind emulated wires (``<simulator wire="true">``).

The simulated bench (``ares.sim.make_sim_bench``) is the device side. The host side is
the real hardware classes -- ``I2CRegisterBus`` over smbus2 messages, ``UsbFrameSource``
over pyusb, ``SerialLightSource``/``SerialChamber`` over pyserial -- talking to emulators
(``ares.hardware.emulators``) that speak the bytes the system XML declares. With the same
seed the frames are bit-identical to the direct simulated bench (a test shows it), so
every byte path is exercised by any scan, and faults can be injected on each wire.
"""

from __future__ import annotations

from ares.errors import InputError
from ares.hardware.interfaces import Bench
from ares.hardware.registers import RegisterMap


def wire_faults() -> tuple[str, ...]:
    from ares.hardware.emulators import i2c_device, serial_device, usb_device

    return usb_device.FAULTS + i2c_device.FAULTS + serial_device.FAULTS


# The simulator's device faults as the wire shows them (issue 49: given to the simulator behind the
# wire they raised its Python exceptions straight through the emulator into the host code, so no
# byte path saw them): the grabber unplugged at that frame, found again at that search; a frame
# cut short on the wire.
WIRE_EQUIVALENT = {"disconnect_after_frames": "usb_disconnect_at", "reconnect_after_polls": "usb_reconnect_after_polls",
                   "short_frame_at": "usb_short_at"}


def _split_faults(faults: dict | None) -> tuple[dict, dict]:
    """(the simulator's faults: device physics -- a settling LED, a lagging pipeline, a slow
    frame; the wire's), the simulator's device faults moved onto the wire (``WIRE_EQUIVALENT``)."""
    from ares.sim.bench import _FAULTS as SIM

    faults = dict(faults or {})
    wire = wire_faults()
    unknown = sorted(k for k in faults if k not in wire and k not in SIM)
    if unknown:
        raise InputError(f"unknown fault(s) {unknown} (known: {', '.join(SIM + wire)})")
    for k, w in WIRE_EQUIVALENT.items():
        if k in faults:
            if w in faults:
                raise InputError(f"faults {k} and {w} are the same fault on the wire: give one")
            faults[w] = faults.pop(k)
    return {k: v for k, v in faults.items() if k in SIM}, {k: v for k, v in faults.items() if k in wire}


def _aresemu_name(port: str) -> str | None:
    return port.split("://", 1)[1].strip("/") if port.startswith("aresemu://") else None


def build_wire_bench(system, seed: int, faults: dict | None = None, uses: set | None = None) -> Bench:
    from ares.hardware.emulators.i2c_device import EmulatedSMBus
    from ares.hardware.emulators.sensor_registers import device_registers
    from ares.hardware.emulators.serial_device import EmulatedChamber, EmulatedInstrument, register, unregister
    from ares.hardware.emulators.usb_backend import EmulatedUsbBackend
    from ares.hardware.emulators.usb_device import EmulatedGrabber
    from ares.sim.from_system import sim_params
    from ares.hardware.i2c import ImageRowReadback
    from ares.sim.bench import SimRegisterBus
    from ares.hardware.serial_instruments import SerialChamber, SerialLightSource
    from ares.hardware.usb import UsbFrameSource
    from ares.sim import make_sim_bench

    src = system.source or system.name
    if not system.buses or system.usb_grabber is None:
        raise InputError(f"{src}: <simulator wire='true'> needs <buses><i2c> and <devices><usb_grabber> to emulate")
    sim_f, wire_f = _split_faults(faults)
    dev = make_sim_bench(sim_params(system), seed, sim_f)
    from ares.rig.buses import open_buses, sensor_bus, verify_after_frames

    s, m, b, g = system.sensor, system.registers, sensor_bus(system), system.usb_grabber
    readback = b.readback == "image_row"
    sensor_regs = device_registers(m, dev.registers.bus)
    smbus = EmulatedSMBus(b.address, sensor_regs, address_bits=m.address_bits, value_bits=m.value_bits,
                          value_endian=b.value_endian, faults=wire_f, readable=not readback,
                          clock=dev.clock, speed_hz=b.speed_hz)  # (a transaction takes its bus time on the bench's clock)
    others = {}  # the other I2C devices: register files of their own behind their own adapters
    for o in system.buses:
        if o is not b:
            own = RegisterMap(m.address_bits, m.value_bits, m.endian, tuple(f for f in m.fields if f.bus == o.name))
            others[o.name] = EmulatedSMBus(o.address, SimRegisterBus(own, name=o.name), address_bits=m.address_bits,
                                           value_bits=m.value_bits, value_endian=o.value_endian)
    regs, bus, buses = open_buses(system, lambda x: smbus if x is b else others[x.name])
    grabber = EmulatedGrabber(dev.frames, g, channels=s.adc_channels, interleave=s.adc_interleave, faults=wire_f,
                              serial=g.serial or "ARES-EMU-0001",
                              embed=(b.readback_row, b.readback_start, dev.registers.bus, m.value_bits)
                              if readback else None,
                              latency=lambda: dev.registers.get("exposure") + system.timing.readout_s)
    t = g.trigger
    grabber.line.generator = t is not None and t.mode == "hardware"  # a pulse generator on the trigger input
    emulated, opened = [], list(buses)
    try:
        frames = UsbFrameSource.open(g, (s.rows, s.cols), s.adc_bits, backend=EmulatedUsbBackend([grabber]),
                                     channels=s.adc_channels, interleave=s.adc_interleave)
        frames.exposure_paced = False  # the simulator behind the emulated wire computes its frames
        opened.append(frames)
        verify_after_frames(frames, buses)
        if hasattr(sensor_regs, "frame_boundary"):  # a double-buffered sensor latches at each frame's start
            grabber.on_frame_start = sensor_regs.frame_boundary
            grabber.blanking = sensor_regs  # (usb_frame_in_flight=2: the next frame starts after a blanking)
        if readback:
            bus.readback = ImageRowReadback(bus, frames, b.readback_row, b.readback_start)
        bus.connect()
        from ares.rig.instruments import open_instrument

        inst, unavailable = {}, {}
        for role, cfg, emu, host, device in (("light", system.light_source, EmulatedInstrument, SerialLightSource,
                                              dev.light),
                                             ("chamber", system.chamber, EmulatedChamber, SerialChamber, dev.chamber)):
            if cfg is None:
                continue
            name = _aresemu_name(cfg.port)
            if name is None:
                raise InputError(f"{src}: <{'light_source' if role == 'light' else 'chamber'} port='{cfg.port}'> "
                                 "must be aresemu://NAME in a wire-emulated system")
            e = emu(device, wire_f, clock=dev.clock)  # (its record of a change: on the bench's clock)
            register(name, e)
            emulated.append((name, e))
            inst[role] = open_instrument(role, lambda host=host, cfg=cfg: host.open(cfg, sleep=dev.clock.sleep,
                                                                                 clock=dev.clock.now), uses, unavailable)
            # (its waits -- settle_s, a chamber's polls -- on the bench's clock, as the device's changes are)
            opened.append(inst[role])
    except BaseException:
        for d in opened:
            if d is not None:
                d.close()
        for name, e in emulated:
            unregister(name, e)
        raise
    info = {k: v for k, v in dev.info.items()}
    info.update(system=system.name, wire=True, grabber_serial=grabber.serial)
    if unavailable:  # instruments the scan does not use that did not answer
        info["unavailable"] = unavailable
    bench = Bench(regs, frames, inst.get("light"), inst.get("chamber"), info, clock=dev.clock)
    if "usb_gone_s" in wire_f or dev.recovery_clock is not None:  # the device is away (the LED settles) for
        bench.recovery_clock = dev.clock  # seconds of the bench's clock: a recovery waits on it
    bench.closers.extend(lambda n=n, e=e: unregister(n, e) for n, e in emulated)
    bench.emulators = {"usb": grabber, "i2c": smbus, **{n: e for n, e in emulated}, "device": dev,
                       **{f"i2c:{n}": e for n, e in others.items()}, "sensor_registers": sensor_regs}
    from ares.rig.spectral import attach_simulated

    try:
        attach_simulated(bench, system, dev, wire_f, seed)
    except BaseException:
        bench.close()
        raise
    return bench
