"""Apply a stage's resolved settings to a bench (slow instruments first, light last)."""

from __future__ import annotations

from ares.errors import InputError


def apply_settings(bench, system, settings: dict, previous: dict | None = None, cancel=None) -> None:
    """Write every setting; instruments only settle when their value changed. ``cancel``:
    a callable that is true when the run is asked to stop; an instrument's wait then ends
    with ``ares.hardware.waits.Interrupted``."""
    prev = previous or {}
    for key, value in settings.items():
        changed = prev.get(key) != value
        if key == "temperature":
            if bench.chamber is None:
                raise InputError(f"system '{system.name}' has no thermal chamber to set {value:g} C")
            if changed:
                bench.chamber.set_temperature(value)
                bench.chamber.settle(cancel)
        elif key == "light":
            if bench.light is None:
                if value == 0:
                    continue
                raise InputError(f"system '{system.name}' has no light source to set level {value:g}")
            if changed:
                bench.light.set_level(value)
                bench.light.settle(cancel)
        elif (name := register_field(system, key)) is not None:
            bench.registers.set(name, value)
        else:  # the protocol layer admits no other key
            raise InputError(f"unknown setting '{key}'")


def as_fields(system, settings: dict) -> dict:
    """A stage's settings as the bench's frame source names them: register field ->
    physical value (``exposure`` and ``analog_gain`` by the system's control fields),
    ``light`` and ``temperature`` as they are."""
    return {register_field(system, key) or key: value for key, value in settings.items()}


def register_field(system, key: str) -> str | None:
    """The register field a setting writes (``exposure``/``analog_gain``: the system's
    control fields; ``reg:NAME``: NAME), None for an instrument's (light, temperature)."""
    if key in ("exposure", "analog_gain"):
        return getattr(system.controls, key)
    return key[4:] if key.startswith("reg:") else None
