"""protocols/sim_wire.xml at 48x64 pixels for tests whose subject is the wires, not the
pixels: every device, wire, packet rule and fault as declared, a frame of 9 USB packets
instead of 900."""

from __future__ import annotations

from pathlib import Path

WIRE = Path(__file__).resolve().parents[1] / "protocols" / "sim_wire.xml"
ROWS, COLS = 48, 64


def small_wire(tmp_path: Path) -> Path:
    p = tmp_path / "sim_wire_48x64.xml"
    text = WIRE.read_text().replace('rows="480" cols="640"', f'rows="{ROWS}" cols="{COLS}"')
    text = text.replace('name="rows" type="int" value="480"', f'name="rows" type="int" value="{ROWS}"')
    p.write_text(text.replace('name="cols" type="int" value="640"', f'name="cols" type="int" value="{COLS}"'))
    return p
