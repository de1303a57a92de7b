"""Issue 49's third item left undone: the direct simulator (not behind the emulated wires) has no
trigger modes, and a ``<trigger>`` on a system it stands in for was silently ignored. It is refused
when the file is read, in one sentence naming the file and line; behind the wires the emulated
grabber honours it (tests/test_usb_trigger.py), and a free-running ``<trigger>`` without a strobe
is what the simulator does anyway."""

from __future__ import annotations

from pathlib import Path

import pytest

from ares.errors import InputError
from ares.protocol import load_system

ROOT = Path(__file__).resolve().parents[1]
GRABBER_END = "</usb_grabber>"


def _direct(tmp_path: Path, trigger: str, wire: bool = False, genicam: bool = False) -> Path:
    text = (ROOT / "protocols" / "sim_wire.xml").read_text()
    controls = ('<control when="trigger_mode" request_type="0x40" request="0xC1" value="mode"/>'
                '<control when="trigger" request_type="0x40" request="0xC3" value="0"/>'
                '<control when="strobe" request_type="0x40" request="0xC2" value="strobe"/>')
    if genicam:
        text = text.replace(GRABBER_END, GRABBER_END + f'\n    <genicam name="cam" cti="genicam:viky.cti">{trigger}</genicam>')
    else:
        text = text.replace(GRABBER_END, controls + trigger + GRABBER_END)
    p = tmp_path / "sim_trigger.xml"
    p.write_text(text if wire else text.replace('wire="true"', 'wire="false"'))
    return p


@pytest.mark.parametrize("trigger", ['<trigger mode="hardware" line="0"/>', '<trigger mode="software"/>',
                                     '<trigger mode="free_run" strobe="exposure" strobe_line="1"/>'])
def test_a_trigger_on_the_direct_simulator_is_one_sentence_with_file_and_line(tmp_path, trigger):
    p = _direct(tmp_path, trigger)
    line = next(k for k, t in enumerate(p.read_text().splitlines(), 1) if "<trigger" in t)
    with pytest.raises(InputError, match=rf"^{p}:{line}: <usb_grabber><trigger mode='\w+' strobe='\w+'> is not "
                                         r"modelled by the direct simulator.*wire=\"true\".*remove the <trigger>$"):
        load_system(p)


def test_the_wire_simulator_takes_the_grabbers_trigger_but_not_a_cameras(tmp_path):
    assert load_system(_direct(tmp_path, '<trigger mode="hardware" line="0"/>', wire=True)).usb_grabber.trigger.mode \
        == "hardware"
    assert load_system(_direct(tmp_path, '<trigger mode="free_run"/>')).usb_grabber.trigger.mode == "free_run"
    with pytest.raises(InputError, match=r"sim_trigger\.xml:\d+: <genicam><trigger mode='software' strobe='off'> is "
                                         r"not emulated"):
        load_system(_direct(tmp_path, '<trigger mode="software"/>', wire=True, genicam=True))
