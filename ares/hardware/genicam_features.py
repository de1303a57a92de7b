"""Typed GenICam features: a value is checked against the node's own type and limits before
it is set, and a ``<feature>`` field of a camera carries the camera's value unquantized.

GenApi nodes are Integer (min, max, increment), Float (min, max, an increment when the
camera declares one), Enumeration (its symbolic entries), Boolean and String. The type is
read from the node itself (``symbolics`` = Enumeration; else the Python type of its value,
as harvesters/genicam return it), so the same code serves the genicam wheel's nodes and a
GenTL-free model of them. A value the node cannot take is one sentence naming the camera,
the feature, the value and what it takes (``ValueOutOfRange``) -- nothing is written.

``FeatureFile`` is the ``RegisterFile`` of a camera: ``set``/``get`` pass physical / scale
as the feature's own number (29.97 fps stays 29.97, -3 dB is -3), where an I2C register
field rounds to an unsigned raw integer.
"""

from __future__ import annotations

import math

from ares.errors import HardwareError, InputError, ValueOutOfRange
from ares.hardware.registers import RegisterFile
from ares.hardware.serial_instruments import range_text

_TRUE, _FALSE = ("true", "1", "on"), ("false", "0", "off")


def kind(node) -> str:
    """"enumeration", "boolean", "integer", "float" or "string"."""
    if hasattr(node, "symbolics"):
        return "enumeration"
    v = node.value
    return {bool: "boolean", int: "integer", float: "float"}.get(type(v), "string")


def _limits(node, what: str):
    try:
        return getattr(node, what)
    except Exception:  # a node without that limit (GenApi raises when it is not implemented)
        return None


def _inc(node):
    has = getattr(node, "has_inc", None)
    if callable(has) and not has():
        return None
    inc = _limits(node, "inc")
    return inc if inc else None


def coerce(camera: str, name: str, node, value):
    """``value`` (a number or text from the XML/scan) as ``node`` takes it, checked."""
    k = kind(node)
    where = f"{camera}: feature {name}"
    if k == "enumeration":
        entries = [str(s) for s in node.symbolics]
        if str(value) not in entries:
            raise ValueOutOfRange(f"{where} is an Enumeration: '{value}' is not one of {', '.join(entries)}")
        return str(value)
    if k == "boolean":
        text = str(value).strip().lower()
        if text in _TRUE or text in _FALSE:
            return text in _TRUE
        raise ValueOutOfRange(f"{where} is a Boolean: '{value}' is not true/false")
    if k == "string":
        return str(value)
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueOutOfRange(f"{where} is a{'n Integer' if k == 'integer' else ' Float'}: '{value}' is not a "
                              "number") from None
    if not math.isfinite(v):
        raise ValueOutOfRange(f"{where}: {value} is not a finite number")
    lo, hi, inc = _limits(node, "min"), _limits(node, "max"), _inc(node)
    if k == "integer" and v != round(v):
        raise ValueOutOfRange(f"{where} is an Integer: {value} is not a whole number")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueOutOfRange(f"{where}: {v:g} is outside {range_text(lo, hi, '')}")
    if inc is not None:
        base = lo if lo is not None else 0
        steps = (v - base) / inc
        if abs(steps - round(steps)) > 1e-9 * max(1.0, abs(steps)):
            below = base + math.floor(steps) * inc
            raise ValueOutOfRange(f"{where}: {v:g} is not on its increment {inc:g} from {base:g} "
                                  f"(nearest: {below:g} or {below + inc:g})")
    return int(round(v)) if k == "integer" else v


class FeatureFile(RegisterFile):
    """Named ``<feature>`` fields of a camera, set and read as the features' own numbers
    (field limits from the XML first, then the node's type and limits)."""

    def __init__(self, regmap, bus):
        super().__init__(regmap, bus)  # the FeatureBus: Bench.close closes the camera through it
        self.camera = bus.camera
        self.nodes = {f.field: f.node for f in bus.camera.cfg.features}

    def set(self, name: str, physical: float) -> None:
        f = self.map.field(name)
        if f.access == "ro":
            raise InputError(f"register field '{name}' is read-only and cannot be written")
        physical = float(physical)
        f.check(physical)
        self.camera.write(self.nodes[name], (physical - f.offset) / f.scale)

    def get(self, name: str) -> float:
        f = self.map.field(name)
        node = self.nodes[name]
        try:
            v = self.camera.node(node).value
        except InputError:
            raise
        except Exception as exc:
            raise HardwareError(f"{self.camera.name}: cannot read feature {node} ({exc})") from None
        return f.offset + f.scale * float(v)

    def set_raw(self, name: str, raw: int) -> None:
        self.set(name, self.map.field(name).to_physical(raw))

    def get_raw(self, name: str) -> int:
        f = self.map.field(name)
        return int(round((self.get(name) - f.offset) / f.scale))
