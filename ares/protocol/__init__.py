"""XML protocol layer: system and scan files -> frozen, checked dataclasses.

Parsing is safe (no DTD, no entities, no network, nothing evaluated); every error a
user can cause is one sentence ``file:line: ...`` raised as ``InputError``.

May import ``sim`` (its physical ranges), ``hardware`` (register maps, pixel formats, line
protocols), ``analysis`` (defect thresholds) and the base modules."""

from ares.protocol.scan import Axis, Limit, Output, Scan, Setting, StageSpec, load_scan
from ares.protocol.scan_write import save_scan
from ares.protocol.system import (Controls, I2CBus, Region, SerialInstrument, Sensor, Simulator, System,
                                  Timing, UsbGrabber, load_system, save_system)
from ares.protocol.xmlsafe import load as load_xml


def validate_file(path) -> str:
    """Validate a system or scan XML (chosen by its root element); returns the kind."""
    from ares.protocol import xmlsafe

    tree = xmlsafe.parse(xmlsafe.read_bytes(path), path)
    root = tree.getroot().tag
    if root == "scan":
        load_scan(path)
    elif root == "system":
        load_system(path)
    else:
        shown = root if isinstance(root, str) else "?"
        raise xmlsafe.fail(path, tree.getroot().sourceline,
                           f"root element must be <scan> or <system>, got <{shown}>")
    return root


__all__ = [
    "Axis", "Limit", "Output", "Scan", "Setting", "StageSpec", "load_scan", "save_scan", "Controls", "I2CBus",
    "Region", "SerialInstrument", "Sensor", "Simulator", "System", "Timing", "UsbGrabber", "load_system",
    "save_system", "validate_file", "load_xml",
]
