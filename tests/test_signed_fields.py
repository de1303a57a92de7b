"""Negative GenICam values (issue 49): ``gain_db=-3`` on a camera whose Gain feature goes to
-3 dB is accepted by the scan, written to the camera as -3 and read back as -3 (the feature
fields are two's complement, as a ``<field signed="true">`` register is)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ares.errors import ValueOutOfRange
from ares.hardware.genicam import FeatureBus, feature_map
from ares.hardware.registers import Field, RegisterFile, RegisterMap
from ares.protocol import load_scan, load_system, save_system

FORMAT = Path(__file__).resolve().parents[1] / "ares" / "protocol" / "FORMAT.md"


def _gev(tmp_path: Path) -> Path:
    blk = [b for b in re.findall(r"```xml\n(.*?)```", FORMAT.read_text(), re.S) if 'name="gev_camera"' in b][0]
    p = tmp_path / "gev.xml"
    p.write_text(blk)
    return p


def test_a_negative_gain_db_is_accepted_written_and_read_back(tmp_path):
    scan = tmp_path / "s.xml"
    scan.write_text(f"""<?xml version="1.0"?>
<scan name="g" version="1"><system href="{_gev(tmp_path)}"/>
<settings><set quantity="exposure" value="0.01"/><set field="gain_db" value="-3"/></settings>
<frames>2</frames><stages><stage name="d" scene="dark"/></stages></scan>""")
    sc = load_scan(scan)
    assert dict((s.key, s.value) for s in sc.settings)["reg:gain_db"] == -3

    class Camera:  # the node map of a camera: what was written is what reads back
        cfg = sc.system.genicam
        name = "fake camera"

        def __init__(self):
            self.nodes = {}

        def write(self, node, value):
            self.nodes[node] = value

        def node(self, node):
            return type("N", (), {"value": float(self.nodes[node])})

    cam = Camera()
    regs = RegisterFile(feature_map(sc.system.genicam), FeatureBus(cam))
    regs.set("gain_db", -3.0)
    assert cam.nodes["Gain"] == -3 and regs.get("gain_db") == -3.0
    with pytest.raises(ValueOutOfRange):
        regs.set("gain_db", -4.0)  # below the feature's declared min


def test_signed_register_field_range_and_round_trip(tmp_path):
    f = Field("offset", 0x10, 0, 7, signed=True, minimum=-128, maximum=127)
    assert f.to_raw(-1) == 0xFF and f.to_physical(0xFF) == -1 and f.to_physical(0x7F) == 127
    with pytest.raises(ValueOutOfRange, match="signed"):
        Field("x", 0, 0, 7, signed=True).to_raw(128)
    regs = {}
    bus = type("B", (), {"read": lambda s, a: regs.get(a, 0), "write": lambda s, a, v: regs.__setitem__(a, v),
                         "name": "dict"})()
    rf = RegisterFile(RegisterMap(16, 8, "big", (f,)), bus)
    rf.set("offset", -100)
    assert regs[0x10] == 256 - 100 and rf.get("offset") == -100
    sy = load_system(_gev(tmp_path))
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").genicam == sy.genicam
