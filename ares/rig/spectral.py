"""The spectral bench's devices (EMVA 1288 4.0 Linear, Section 9): the monochromator and the
reference photodiode a system XML declares (``<monochromator>``, ``<photodiode>``).
A simulated monochromator's grating moves on the bench's clock (``ares.sim.spectral.GratingDrive``:
a move takes a time that grows with its size), its emulator records each change, and the host's
serial instruments wait on that clock too.

On a real bench they are opened on their serial ports. On a simulated system (direct or
behind the wires) the simulator's own (``ares.sim.spectral``) stand behind ARES's emulators
of their meters on the declared ``aresemu://NAME`` ports, and the host side is the same
serial code as on the bench, speaking the XML's line protocol."""

from __future__ import annotations

from ares.errors import InputError


def open_spectral(bench, system, opened: list) -> None:
    """A real bench: open the declared devices on their ports (each added to ``opened``)."""
    from ares.hardware.serial_instruments import SerialMonochromator, SerialPhotodiode

    if system.monochromator is not None:
        bench.monochromator = SerialMonochromator.open(system.monochromator)
        opened.append(bench.monochromator)
    if system.photodiode is not None:
        bench.photodiode = SerialPhotodiode.open(system.photodiode.serial, reading=system.photodiode.reading)
        opened.append(bench.photodiode)


def attach_simulated(bench, system, device, faults: dict | None = None, seed: int = 0) -> None:
    """A simulated system: the simulator's monochromator and photodiode (``device``: the
    simulated bench whose frame source and light they share) behind their emulators."""
    if system.monochromator is None and system.photodiode is None:
        return
    from ares.analysis.optics.spectral_qe import responsivity_at
    from ares.hardware.emulators.serial_device import (EmulatedMonochromator, EmulatedPowerMeter, register,
                                                        unregister)
    from ares.hardware.serial_instruments import SerialMonochromator, SerialPhotodiode
    from ares.sim.spectral import GratingDrive, SimMonochromator, SimPhotodiode

    src = system.source or system.name
    params = device.frames.sensor.params
    clock = device.clock  # the bench's: the grating moves on it, and the host's waits run on it
    drive = GratingDrive(params.mono_slew_nm_s, params.mono_accel_nm_s2, params.mono_backlash_nm, params.mono_settle_s)
    mono = SimMonochromator(params.mono_fwhm_nm, clock=clock, drive=drive)
    device.frames.monochromator = mono
    on_clock = {"sleep": clock.sleep, "clock": clock.now} if clock is not None else {}
    pending = []
    if system.monochromator is not None:
        pending.append(("monochromator", system.monochromator, EmulatedMonochromator(mono, faults, clock=clock),
                        lambda cfg: SerialMonochromator.open(cfg, **on_clock)))
    if system.photodiode is not None:
        pd = system.photodiode
        t = pd.table
        pitch = system.sensor.pixel_pitch_um or params.pixel_pitch_um
        sim_pd = SimPhotodiode(device.light, mono, params, pitch, pd.area_mm2,
                               lambda nm: _responsivity(responsivity_at, t, nm), pd.reading, seed)
        pending.append(("photodiode", pd.serial, EmulatedPowerMeter(sim_pd, faults),
                        lambda cfg: SerialPhotodiode.open(cfg, reading=pd.reading, **on_clock)))
    for role, cfg, emu, opener in pending:
        if not cfg.port.startswith("aresemu://"):
            raise InputError(f"{src}: <{role} port='{cfg.port}'> must be aresemu://NAME on a simulated system "
                             "(the simulator's device stands behind ARES's emulator of its meter)")
        name = cfg.port.split("://", 1)[1].strip("/")
        register(name, emu)
        bench.closers.append(lambda n=name, e=emu: unregister(n, e))
        if isinstance(getattr(bench, "emulators", None), dict):  # (a wire bench's: the devices' records, by name)
            bench.emulators[name] = emu
        setattr(bench, role, opener(cfg))
    bench.info["spectral"] = {"mono_fwhm_nm": params.mono_fwhm_nm}


def _responsivity(responsivity_at, table, nm: float) -> float:
    """The table's responsivity; beyond it, its end values (the simulated diode still sees light)."""
    nm = min(max(nm, table.wavelength_nm[0]), table.wavelength_nm[-1])
    return responsivity_at(table.wavelength_nm, table.responsivity_a_per_w, table.u_a_per_w, nm)[0]
