"""Transient USB faults recover (issue 49): a frame late past the read timeout, a stalled
endpoint (EPIPE -> clear_halt), a bulk timeout, a short frame, and an unplug of 5 s and of
60 s (emulated time: the bench's clock, no wall time) under ``<suspend>`` with a device
condition all end ``done``, each loss recorded; a reconnect disposes of the old handle and
reads the packet size anew. Without ``<suspend>`` the same fault still fails the run in one
sentence (the re-grab is what recovers, not a silent skip)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ares.errors import FrameLost
from ares.protocol import load_scan
from ares.rig.factory import build_bench
from ares.scan import Runner
from wire_small import small_wire


def _scan(tmp_path: Path, suspend: bool = True) -> Path:
    system = small_wire(tmp_path)
    text = system.read_text().replace('timeout_ms="2000"', 'timeout_ms="200"')  # a timeout costs 0.2 s of wall
    system.write_text(text)
    sus = ('<suspend poll_s="0.5" hold_s="0" timeout_s="120" max_recoveries="3">'
           '<condition quantity="device"/></suspend>') if suspend else ""
    p = tmp_path / "transient.xml"
    p.write_text(f"""<?xml version="1.0"?>
<scan name="transient" version="1">
  <system href="{system}"/>
  <settings><set quantity="exposure" value="0.01"/></settings>
  <frames>3</frames>
  <stages>
    <stage name="dark" scene="dark"/>
    <sweep name="ptc" scene="flat"><axis quantity="light"><values>1e5 3e5</values></axis></sweep>
  </stages>
  {sus}
  <output pdf="false" csv="false" hdf5="false"/>
</scan>
""")
    return p


def _run(tmp_path: Path, faults: dict, suspend: bool = True):
    scan = load_scan(_scan(tmp_path, suspend))
    bench = build_bench(scan.system, seed=1, faults=faults)
    try:
        return Runner(scan, bench=bench).run(), bench
    finally:
        bench.close()


AT = 9  # a device frame in the second stage (probe frames included)
CASES = {
    "late frame 1.2 s": ({"usb_late_at": AT, "usb_late_ms": 1200}, "timeout"),
    "endpoint stall": ({"usb_stall_at": AT}, "stall"),
    "bulk timeout": ({"usb_timeout_at": AT}, "timeout"),
    "short frame": ({"usb_short_at": AT}, "short"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_transient_fault_is_regrabbed_under_suspend(tmp_path, case):
    faults, kind = CASES[case]
    outcome, bench = _run(tmp_path, faults)
    assert outcome.status == "done", outcome.message
    lost = [x for st in outcome.stages for x in st.get("frames_lost", [])]
    assert [x["kind"] for x in lost] == [kind], lost
    assert len(outcome.stages) == 3
    if kind == "stall":
        assert bench.frames.stalls == 1 and not bench.emulators["usb"].halted


def test_without_suspend_a_transient_fault_fails_in_one_sentence(tmp_path):
    scan = load_scan(_scan(tmp_path, suspend=False))
    bench = build_bench(scan.system, seed=1, faults={"usb_stall_at": AT})
    try:
        with pytest.raises(FrameLost, match=r"endpoint 0x81 stalled .*EPIPE; the halt was cleared"):
            Runner(scan, bench=bench).run()
    finally:
        bench.close()


@pytest.mark.parametrize("gone_s", [5, 60])
def test_unplug_in_emulated_time_ends_done(tmp_path, gone_s):
    """Unplugged for 5 s or 60 s of the bench's clock: the recovery waits on that clock, so the
    test takes no wall time; the pause is recorded with its (emulated) seconds."""
    outcome, bench = _run(tmp_path, {"usb_disconnect_at": AT, "usb_gone_s": gone_s, "usb_reconnect_packet": 1024})
    assert outcome.status == "done", outcome.message
    pauses = [p for st in outcome.stages for p in st.get("suspensions", [])]
    assert len(pauses) == 1 and pauses[0]["device"] == "frames"
    assert gone_s <= pauses[0]["seconds"] <= 2 * gone_s + 8, pauses
    usb = bench.emulators["usb"]
    assert usb.handles_closed >= 1  # the old handle was let go
    assert bench.frames.max_packet == 1024  # the descriptor read anew: it came back at another speed
