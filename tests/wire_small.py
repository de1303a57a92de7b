"""protocols/sim_wire.xml at 48x64 pixels for tests whose subject is the wires, not the
pixels: every device, wire, packet rule and fault as declared, a frame of 9 USB packets
instead of 900."""

from __future__ import annotations

from pathlib import Path

WIRE = Path(__file__).resolve().parents[1] / "protocols" / "sim_wire.xml"
ROWS, COLS = 48, 64


HOLD = '<group_hold register="0x0104" hold="0x01" release="0x00"/>'  # sim_wire.xml's (a stage's writes atomic)


def small_wire(tmp_path: Path, hold: bool = True) -> Path:
    """``hold=False``: without sim_wire's group hold (each register written on its own)."""
    p = tmp_path / "sim_wire_48x64.xml"
    text = WIRE.read_text().replace('rows="480" cols="640"', f'rows="{ROWS}" cols="{COLS}"')
    assert HOLD in text
    if not hold:
        text = text.replace(HOLD, "")
    text = text.replace('name="rows" type="int" value="480"', f'name="rows" type="int" value="{ROWS}"')
    p.write_text(text.replace('name="cols" type="int" value="640"', f'name="cols" type="int" value="{COLS}"'))
    return p
