"""The monochromator's ``complete`` command (``*OPC?``, FORMAT.md "Spectral bench"): the host
waits on it after every wavelength change for at most its ``timeout_s`` -- on the bench's
clock, where the emulated grating's move takes its time -- and a monochromator that never
answers fails the stage with one sentence naming it (exit 3), never a hang.

The stalled device is an emulator whose ``*OPC?`` gets no reply, behind ports that wait as a
serial port waits: a read with nothing to read blocks on an event nobody sets for the port's
timeout (a read without one would block for ever: the test says so instead of hanging). The
test XML's 0.2 s only bounds those waits; nothing is asserted about wall-clock time."""

from __future__ import annotations

import shutil
import threading
from pathlib import Path

import pytest

from ares.cli import main
from ares.errors import HardwareError
from ares.hardware.emulators import protocol_aresemu
from ares.hardware.emulators.serial_device import EmulatedMonochromator
from ares.protocol import load_system

ROOT = Path(__file__).resolve().parents[1]
SCAN = """<?xml version="1.0" encoding="UTF-8"?>
<scan name="mono_wait" version="1">
  <system href="sim_spectral.xml"/>
  <settings><set quantity="exposure" value="0.01"/><set quantity="analog_gain" value="1"/>
    <set quantity="light" value="1000000"/></settings>
  <frames>2</frames>
  <stages>
    <stage name="at700" scene="flat"><set quantity="wavelength" value="700"/></stage>
  </stages>
  <output pdf="false"/>
</scan>
"""
SILENT = "cs130 on aresemu://cs130: no reply to '*OPC?' within 0.2 s (timeout: the instrument is silent, its port open)"


def _bench_dir(tmp_path: Path, timeout_s: str = "0.2") -> Path:
    """sim_spectral.xml with the ``complete`` command's timeout_s, its calibration table, the scan."""
    text = (ROOT / "protocols" / "sim_spectral.xml").read_text()
    old = '<command name="complete" send="*OPC?" reply="1" timeout_s="30"/>'
    assert old in text
    (tmp_path / "sim_spectral.xml").write_text(text.replace(old, old.replace('"30"', f'"{timeout_s}"')))
    shutil.copy(ROOT / "protocols" / "sim_spectral_pd.csv", tmp_path)
    (tmp_path / "scan.xml").write_text(SCAN)
    return tmp_path


@pytest.fixture
def stalled(monkeypatch):
    """The monochromator never answers ``*OPC?``; every emulated port waits as a serial port does.
    Returns the timeouts the host's reads waited with (one per empty read)."""
    waits: list = []
    never = threading.Event()  # nobody sets it: the reply never comes
    read = protocol_aresemu.Serial.read

    def waiting_read(self, size=1):
        out = read(self, size)
        if not out:
            waits.append(self.timeout)
            if self.timeout is None:
                raise AssertionError("a read without a timeout: a silent device would hang the host")
            never.wait(self.timeout)
        return out

    answer = EmulatedMonochromator.answer
    monkeypatch.setattr(protocol_aresemu.Serial, "read", waiting_read)
    monkeypatch.setattr(EmulatedMonochromator, "answer",
                        lambda self, cmd, arg: None if cmd == "*OPC?" else answer(self, cmd, arg))
    return waits


def test_a_monochromator_that_never_answers_fails_in_its_timeout(tmp_path, stalled):
    from ares.rig.factory import build_bench

    bench = build_bench(load_system(_bench_dir(tmp_path) / "sim_spectral.xml"))
    try:
        m = bench.monochromator
        m.set_wavelength(632.8)
        with pytest.raises(HardwareError) as e:
            m.settle()
        assert str(e.value) == SILENT
        assert stalled == [pytest.approx(0.2)]  # the complete command's timeout_s, not the instrument's 2 s, once
        assert m.port.instrument.log[-2:] == ["GOWAVE 632.80", "*OPC?"] and m.timeouts == 1
    finally:
        bench.close()


def test_the_stage_fails_with_one_sentence_naming_the_device(tmp_path, stalled, capsys):
    d = _bench_dir(tmp_path)
    assert main(["run", str(d / "scan.xml"), "--out", str(d / "run"), "-q"]) == 3
    err = capsys.readouterr().err
    assert err.startswith(f"ares run: {SILENT} (during stage 0") and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert stalled and all(t == pytest.approx(0.2) for t in stalled)


@pytest.mark.parametrize("timeout_s", ["0.2", "30"])
def test_a_move_longer_than_timeout_s_on_the_bench_clock_is_a_timeout(tmp_path, timeout_s):
    """The emulator answers ``*OPC?`` when its grating has stopped, holding the bench's clock
    as a blocking query holds the host: 550 -> 700 nm takes ~1.2 s, more than 0.2 s (which
    passed before: the reply's time was counted from after the move); the shipped 30 s waits
    for it to the end."""
    from ares.rig.factory import build_bench

    bench = build_bench(load_system(_bench_dir(tmp_path, timeout_s) / "sim_spectral.xml"))
    try:
        m = bench.monochromator
        m.settle()  # at its 550 nm already: done at once
        t0 = bench.clock.now()
        m.set_wavelength(700)
        if timeout_s == "0.2":
            with pytest.raises(HardwareError) as e:
                m.settle()
            assert str(e.value) == SILENT
        else:
            m.settle()
            assert m.get_wavelength() == 700.0 and 0.5 < bench.clock.now() - t0 < 30
    finally:
        bench.close()
