"""Set point and readback, with the tolerance they must agree to, for every quantity a stage
sets (as ophyd's and PyMoDAQ's setpoint/readback pairs): the stage JSON's ``setpoints``.

Registers are read back from the snapshot the stage takes after its frames (no extra bus
traffic) and agree within half a step of the field (``scale / 2``); the chamber's readback is
its last reading while it settled (tolerance: its ``tolerance=``); a monochromator is asked
its wavelength (tolerance: half its bandwidth, when it knows it). A light source is read back
by its ``read`` command (its monitor of the output; tolerance: its ``tolerance=``); one
without it answers its own set point only -- no independent readback, said so rather than
compared with itself."""

from __future__ import annotations

import math

from ares.scan.apply import register_field


def light_reading(bench) -> float | None:
    """The light source's monitor reading of its output now (None: it gives none)."""
    read = getattr(bench.light, "read_level", None) if bench.light is not None else None
    got = read() if read is not None else None
    return None if got is None else float(got)


def setpoints(bench, system, settings: dict, registers_after: dict, light_read: float | None = None) -> dict:
    """``light_read``: the light monitor's reading taken right after the stage's lit frames --
    a matched dark grabbed after them (``dark="after"``) has turned the light off since, and a
    reading now would compare the dark's level with the stage's set point."""
    out = {}
    for key, value in settings.items():
        if key == "light":
            light = bench.light
            got = light_read if light_read is not None else light_reading(bench)
            if got is not None:  # its monitor's reading of the output, with its tolerance
                out[key] = _pair(value, got, getattr(light, "level_tolerance", None), None)
                continue
            pd = getattr(bench, "photodiode", None)
            out[key] = _pair(value, None, None, "no independent readback: the light source declares no 'read' "
                             "command (it only answers its set point)"
                             + (" (the photodiode's readings are in 'spectral')" if pd is not None else ""))
        elif key == "temperature":
            ch = bench.chamber
            got = getattr(ch, "last_reading", None)
            if got is None and ch is not None and not hasattr(ch, "cfg"):  # the simulator's: its state, no wire
                got = ch.get_temperature()
            tol = getattr(getattr(ch, "cfg", None), "tolerance", None)
            out[key] = _pair(value, got, tol, None if got is not None else "the chamber was not read while it settled")
        elif key == "wavelength":
            mono = getattr(bench, "monochromator", None)
            got = mono.get_wavelength() if mono is not None else None
            bw = mono.bandwidth() if mono is not None else math.nan
            out[key] = _pair(value, got, bw / 2 if math.isfinite(bw) else None, None)
        else:
            name = register_field(system, key)
            if name is None or name not in registers_after:
                continue
            f = system.registers.field(name) if hasattr(system.registers, "field") else None
            want = f.to_physical(f.to_raw(value)) if f is not None else value
            out[key] = _pair(want, registers_after[name], abs(f.scale) / 2 if f is not None else None, None)
    return out


def _pair(set_point, readback, tolerance, note) -> dict:
    d = {"set": float(set_point), "read": None if readback is None else float(readback)}
    if tolerance is not None:
        d["tolerance"] = float(tolerance)
    if readback is not None and tolerance is not None:
        d["ok"] = bool(abs(float(readback) - float(set_point)) <= float(tolerance) * (1 + 1e-9) + 1e-12)
    if note:
        d["note"] = note
    return d
