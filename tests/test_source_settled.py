"""The light on the sensor when a stage keeps its frames under ``<settle by="time">``, judged by
the devices' own records (``ares.scan.source_settled``, ``ares.scan.in_flight``; FORMAT.md,
Bench dynamics): the wire-emulated simulator at 48x64 (protocols/sim_wire.xml), its grabber's
``exposed_with`` (each frame's exposure start on the bench clock and the light it was rendered
with), the emulated monochromator's and light source's ``changes`` (commanded, settled)."""

from __future__ import annotations

import pytest

from ares.errors import HardwareError
from ares.protocol import load_scan
from test_frame_in_flight import MONO, QE, TIMED, _light_scan, _run_recorded

WAVES = (450, 550, 650)  # nm: from the monochromator's 550 at power-up -- down (with backlash), up, up


def _mono_scan(tmp_path, header: str = "ares40", complete: bool = True):
    p = _light_scan(tmp_path, header, quantity="wavelength", values=WAVES)
    system = tmp_path / "sim_wire_48x64.xml"
    mono = MONO if complete else "\n".join(line for line in MONO.split("\n") if 'name="complete"' not in line)
    text = system.read_text().replace("  </devices>", mono, 1)
    system.write_text(text.replace('<simulator seed="1" wire="true">', '<simulator seed="1" wire="true">' + QE, 1))
    return load_scan(p)


def _early(outcome, kept, truth, changes) -> dict:
    """stage -> [(device counter, exposure start, device settled)] of kept frames that started before it."""
    return {st["name"]: [(n, truth[n]["exposure_start_s"], c["settled_s"]) for n in kept[st["index"]]
                         if truth[n]["exposure_start_s"] < c["settled_s"] - 1e-9]
            for st, c in zip(outcome.stages, changes)}


def test_no_kept_frame_started_before_the_grating_settled(tmp_path):
    """The emulated monochromator's grating takes time to move (its record: each ``GOWAVE``'s
    commanded and settled time, growing with the move; a move down runs past the target and comes
    back). The host waits on its ``*OPC?`` (``complete``), so no kept frame started exposing before
    the device says the grating settled, each stage's frames carry one light -- the QE at its
    wavelength -- and the frame the grabber held from before is discarded by its time stamp."""
    outcome, kept, truth, changes = _run_recorded(_mono_scan(tmp_path), {"usb_pipeline_frames": 1}, "cs130")
    assert outcome.status == "done", outcome.message
    assert [c["level"] for c in changes] == list(WAVES)
    took = [c["settled_s"] - c["commanded_s"] for c in changes]
    assert 0.5 < took[1] < 2.0 and took[0] > took[1], took  # 100 nm: ~0.9 s; down 100 nm: + backlash's return
    assert not any(_early(outcome, kept, truth, changes).values())
    flux = [{truth[n]["photon_flux"] for n in kept[st["index"]]} for st in outcome.stages]
    assert all(len(f) == 1 for f in flux) and len(set.union(*flux)) == 3, flux
    for st in outcome.stages:
        rec = st["settling"]["flat"]
        assert rec["sources"]["wavelength"]["verified"] is True and "complete" in rec["sources"]["wavelength"]["why"]
        fl = rec["in_flight"]  # (the first stage: no frame held from a stop before)
        assert fl["evidence"] == "device timestamp" and fl["discarded"] == (1 if st["index"] else 0), fl


def test_the_check_fails_for_a_host_that_trusts_the_set_command(tmp_path, monkeypatch):
    """The same run with the host as it was -- the move taken as done when ``GOWAVE`` is answered
    (no ``*OPC?``, nothing read back): the stage's first frame started while the grating moved
    (the device's record), rendered with the light it passed through -- the test above would fail."""
    from ares.hardware.serial_instruments import SerialMonochromator
    from ares.scan import source_settled

    monkeypatch.setattr(SerialMonochromator, "settle", lambda self, cancel=None: None)
    monkeypatch.setattr(source_settled, "check_sources", lambda *a, **k: {})
    outcome, kept, truth, changes = _run_recorded(_mono_scan(tmp_path), {"usb_pipeline_frames": 1}, "cs130")
    early = _early(outcome, kept, truth, changes)
    assert all(early[st["name"]] for st in outcome.stages), early
    flux = [{truth[n]["photon_flux"] for n in kept[st["index"]]} for st in outcome.stages]
    assert all(len(f) > 1 for f in flux), flux  # the first frame's light is not the stage's


def test_without_complete_the_position_readback_is_the_evidence(tmp_path):
    """A monochromator without ``complete``: the host reads its position back until it is at the
    set point and has stopped (a drive passing through the target on its backlash run is not
    there), says so, and that the ringing after the stop is not seen."""
    outcome, kept, truth, changes = _run_recorded(_mono_scan(tmp_path, complete=False), {"usb_pipeline_frames": 1},
                                                  "cs130")
    assert outcome.status == "done", outcome.message
    for st, c in zip(outcome.stages, changes):
        src = st["settling"]["flat"]["sources"]["wavelength"]
        assert src["verified"] is True and "position readback" in src["why"] and "ringing" in src["why"], src
        starts = [truth[n]["exposure_start_s"] for n in kept[st["index"]]]
        assert min(starts) > c["settled_s"] - 0.05 - 1e-9, (starts, c)  # stopped: within the mount's ringing


SLOW = TIMED.replace('<settle by="time"/>', '<after quantity="light" settle_s="0.005"/><settle by="time"{cap}/>')
MON = '<command name="read" send="MON?" reply="(?P&lt;value&gt;\\S+)"/>'


def _slow_led(tmp_path, monitor: bool = True, cap: str = ""):
    """The light stages of ``_light_scan`` with an LED whose tail (tau 10 ms: ~80 ms to within its
    monitor's tolerance) outlasts the declared 5 ms."""
    p = _light_scan(tmp_path, "ares40", SLOW.format(cap=cap))
    system = tmp_path / "sim_wire_48x64.xml"
    text = system.read_text()
    assert MON in text
    system.write_text(text if monitor else text.replace(MON, ""))
    return load_scan(p)


def test_a_light_slower_than_declared_is_waited_for_by_its_monitor(tmp_path):
    """``<settle by="time">``: after the declared 5 ms the LED's monitor (``MON?``) reads short of the
    set point, so the host waits until it is within its tolerance, and the record says how long and
    why; by the device's record no kept frame started before the output reached its level."""
    outcome, kept, truth, light = _run_recorded(_slow_led(tmp_path), {"light_tau_s": 0.01}, "led")
    assert outcome.status == "done", outcome.message
    for st, change in zip(outcome.stages, light):
        src = st["settling"]["flat"]["sources"]["light"]
        assert src["verified"] and 0.03 < src["waited_s"] < 0.2 and "slower than declared" in src["why"], src
        starts = [truth[n]["exposure_start_s"] for n in kept[st["index"]]]
        assert min(starts) >= change["settled_s"] - 1e-9, (st["name"], starts, change)
        assert all(abs(truth[n]["photon_flux"] - change["level"]) <= 100 for n in kept[st["index"]])
    # the run says so, once (outcome and run.json's message): the declared settle time is too short
    assert "light settled slower than declared" in outcome.message and "<after settle_s>" in outcome.message, \
        outcome.message


def test_a_light_past_the_cap_fails_the_stage_naming_the_device(tmp_path):
    with pytest.raises(HardwareError, match=r"^led: light level not settled .* slower than declared") as exc:
        _run_recorded(_slow_led(tmp_path, cap=' max_s="0.02"'), {"light_tau_s": 0.01})
    assert "\n" not in str(exc.value) and "set 100000 +/- 100" in str(exc.value)  # (stage 1: 0 -> 1e5)


def test_without_a_monitor_settling_is_not_verified_and_says_so(tmp_path):
    """No ``read`` command: nothing tells the host the LED is late -- the record says settling was not
    verified, and the device's record shows why it matters: kept frames started before the light
    reached its level."""
    outcome, kept, truth, light = _run_recorded(_slow_led(tmp_path, monitor=False), {"light_tau_s": 0.01}, "led")
    assert outcome.status == "done", outcome.message
    for st in outcome.stages:
        src = st["settling"]["flat"]["sources"]["light"]
        assert src["verified"] is False and "not verified" in src["why"] and "'read'" in src["why"], src
    early = [n for st, c in zip(outcome.stages, light) for n in kept[st["index"]]
             if truth[n]["exposure_start_s"] < c["settled_s"] - 1e-9]
    assert early, (kept, light)


@pytest.mark.parametrize("quantity", ["wavelength", "wavelenght"])
def test_after_quantity_wavelength_is_accepted_and_a_bad_one_names_the_line(tmp_path, quantity):
    """``<after quantity="wavelength">`` as for the light: its wait and discard after a wavelength
    change, written back by ``save_system``; a quantity ARES does not know is one sentence with file:line."""
    from ares.errors import InputError
    from ares.protocol.system import load_system, save_system

    _mono_scan(tmp_path)
    system = tmp_path / "sim_wire_48x64.xml"
    text = system.read_text().replace('<settle by="time"/>', f'<after quantity="{quantity}" settle_s="0.3" '
                                                             'discard_frames="2"/><settle by="time"/>', 1)
    system.write_text(text)
    if quantity != "wavelength":
        line = text[:text.index("<after ")].count("\n") + 1
        with pytest.raises(InputError, match=rf"{system.name}:{line}: <after quantity=.*wavelength, got 'wavelenght'"):
            load_system(system)
        return
    sy = load_system(system)
    assert sy.timing.after_change("wavelength") == (0.3, 2) and sy.timing.after_change("light") == (0.0, 0)
    save_system(sy, tmp_path / "saved.xml")
    assert load_system(tmp_path / "saved.xml").timing.after_change("wavelength") == (0.3, 2)
    outcome, _, _, changes = _run_recorded(load_scan(tmp_path / "in_flight.xml"), {}, "cs130")
    for st in outcome.stages:
        rec = st["settling"]["flat"]
        assert rec["declared_wait_s"] == 0.3 and rec["discarded"] == 2 and "wavelength" in rec["changed"], rec


def test_the_direct_simulator_light_turned_off_is_waited_for_within_its_monitor_offset(tmp_path):
    """The direct simulator's LED (tau 10 ms) turned off under ``by="time"``: its monitor reads within
    its offset (1 photon/pixel/s) of 0 after a bounded wait -- a relative tolerance alone (0 at 0)
    would never be met: the stage would fail at the cap."""
    p = _light_scan(tmp_path, "ares40", values=(1e5, 0))
    system = tmp_path / "sim_wire_48x64.xml"
    system.write_text(system.read_text().replace('<simulator seed="1" wire="true">', '<simulator seed="1">'))
    outcome, _, _, _ = _run_recorded(load_scan(p), {"light_tau_s": 0.01})
    assert outcome.status == "done", outcome.message
    off = outcome.stages[1]["settling"]["flat"]["sources"]["light"]
    assert off["verified"] and off["tolerance"] == 1.0 and 0.05 < off["waited_s"] < 0.3 and off["read"] <= 1.0, off
