"""The simulated sensor's parameters from a system XML's ``<simulator>`` block, with errors that
name the system file and the parameter's line."""

from __future__ import annotations

from ares.errors import InputError


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


def sensor_layout(regmap):
    """The sensor's own register layout: its fields (not those of other I2C devices, ``bus=``),
    without how its registers behave on the wire (double buffering, group hold, read latch, which bus): the
    emulators add those (``ares.hardware.emulators.sensor_registers``)."""
    from dataclasses import replace

    return replace(regmap, bus=None, group_hold=None, read_latch=None,
                   fields=tuple(replace(f, buffered=None, shadow=None) for f in regmap.fields if f.bus is None))


def sim_params(system):
    """``SensorParams`` from the system's ``<simulator>`` block (array size and ADC bits
    from ``<sensor>``); errors name the system file and the parameter's line."""
    import re

    from ares.sim import SensorParams

    from ares.sim.regmap import SIM_REGISTER_MAP

    d = dict(system.simulator.params)
    src = system.source or system.name
    if sensor_layout(system.registers) != SIM_REGISTER_MAP:
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
