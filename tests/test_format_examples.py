"""The complete system files in ares/protocol/FORMAT.md's "Real bench examples" load (schema
and semantic checks), say what the text says they declare, and survive save -> load."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ares.protocol import load_system, save_system

FORMAT = Path(__file__).resolve().parents[1] / "ares" / "protocol" / "FORMAT.md"


def _examples() -> dict[str, str]:
    text = FORMAT.read_text(encoding="utf-8")
    section = text.split("### Real bench examples", 1)[1].split("\n### ", 1)[0]
    blocks = re.findall(r"```xml\n(.*?)```", section, re.S)
    return {re.search(r'<system name="(\w+)"', b).group(1): b for b in blocks}


def test_the_section_holds_the_four_kinds_of_device():
    ex = _examples()
    assert set(ex) == {"fx3_bench", "gev_camera"}
    joined = "".join(ex.values())
    for tag in ("<usb_grabber", "<i2c", "<light_source", "<genicam"):
        assert tag in joined


@pytest.mark.parametrize("name", sorted(_examples()))
def test_example_loads_and_round_trips(name, tmp_path):
    p = tmp_path / f"{name}.xml"
    p.write_text(_examples()[name], encoding="utf-8")
    sy = load_system(p)
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml") == sy
    if name == "fx3_bench":
        b, g, led = sy.buses[0], sy.usb_grabber, sy.light_source
        assert (b.bus, b.speed_hz, b.chip_id) == (2, 400000, (0x3000, 0x2A5C))
        assert b.init == (("write", 0x0103, 1), ("wait", 0.005, 0), ("write", 0x301A, 0x10DC))
        assert sy.registers.field("soft_reset").volatile and not sy.registers.field("exposure").volatile
        assert g.header_packet == "inline" and g.header == "ares32"
        assert led.protocol.echo and led.protocol.retries == 2 and led.protocol.terminator == "\r\n"
    else:
        assert [f.node for f in sy.genicam.features] == ["ExposureTime", "Gain", "AcquisitionFrameRate"]
        assert sy.registers.field("gain_db").minimum == -3
