"""The frame in flight at a register change is never kept (``ares.scan.apply``; FORMAT.md, Bench
dynamics). With ``<settle by="time">`` and no declared ``discard_frames`` the frame that was
exposing when a stage's registers changed used to be the stage's first kept frame, although it
was exposed (wholly or partly) with the old settings.

The device is the wire-emulated simulator (protocols/sim_wire.xml at 48x64 pixels) with a frame
in flight: ``usb_frame_in_flight=1`` (a streaming sensor: the next frame starts, latching its
registers, as one is read out) or ``usb_pipeline_frames=1`` (a sensor that keeps exposing after a
stop). The grabber's ``exposed_with`` is the device's truth: the settings each frame (by its device
counter) was exposed with; the stage arrays' ``frame_counter`` names the frames the stage kept."""

from __future__ import annotations

from pathlib import Path

import pytest

from ares.errors import InputError
from ares.protocol import load_scan
from ares.protocol.system import load_system, save_system
from ares.rig.factory import build_bench
from ares.scan import Runner
from ares.scan import events as ev
from wire_small import small_wire

TIMED = '<timing readout_s="0.001" settle_s="0"><settle by="time"/></timing>'
# exposure and gain change at every stage (the light stays): the settings tell the stages apart
STAGES = ((0.008, 1.0), (0.004, 2.0), (0.002, 4.0))


def _scan(tmp_path: Path, header: str = "ares32", sim: bool = False, hold: bool = True) -> Path:
    system = small_wire(tmp_path, hold=hold)  # (held: a streaming sensor latches them as the frame in flight
    text = system.read_text().replace('<timing readout_s="0.001" settle_s="0"/>', TIMED)  # starts: the old)
    system.write_text(text.replace('header="ares32"', f'header="{header}"'))
    if sim:  # the direct simulator at the same size: frames stamped at exposure start on its clock
        text = system.read_text().replace('<simulator seed="1" wire="true">', '<simulator seed="1">')
        system.write_text(text)
    stages = "\n".join(f'    <stage name="s{k}" scene="flat"><set quantity="exposure" value="{e}"/>'
                       f'<set quantity="analog_gain" value="{g}"/></stage>' for k, (e, g) in enumerate(STAGES))
    p = tmp_path / "in_flight.xml"
    p.write_text(f"""<?xml version="1.0"?>
<scan name="in_flight" version="1">
  <system href="{system}"/>
  <settings><set quantity="light" value="2e5"/></settings>
  <frames>3</frames>
  <stages>
{stages}
  </stages>
  <output pdf="false" csv="false" hdf5="false"/>
</scan>
""")
    return p


def _run_recorded(scan, faults: dict, instrument: str | None = None):
    """Run ``scan`` on its bench: (outcome, the device counters of the frames each stage kept, by
    stage index, the grabber's per-frame record ``exposed_with`` ({} on the direct simulator), the
    ``instrument`` emulator's record of its changes)."""
    bench = build_bench(scan.system, seed=1, faults=faults)
    kept = {}
    listen = (lambda e: kept.setdefault(e.index, e.arrays["frame_counter"].tolist())
              if isinstance(e, ev.StageFinished) else None)
    try:
        outcome = Runner(scan, bench=bench, listeners=(listen,)).run()
        emu = getattr(bench, "emulators", None) or {}
        truth = dict(emu["usb"].exposed_with) if emu else {}
        return outcome, kept, truth, list(emu[instrument].changes) if instrument else []
    finally:
        bench.close()


def _run(scan_path: Path, faults: dict):
    """(outcome, the device counters of the frames each stage kept, the device's truth, each
    stage's settling record of its change)."""
    outcome, kept, truth, _ = _run_recorded(load_scan(scan_path), faults)
    assert outcome.status == "done", outcome.message
    return outcome, [kept[st["index"]] for st in outcome.stages], truth, [st["settling"]["flat"] for st in outcome.stages]


@pytest.mark.parametrize("fault,hold", [("usb_frame_in_flight", True), ("usb_pipeline_frames", False)],
                         ids=["streaming_latched", "exposed_at_stop"])
def test_no_kept_frame_was_exposed_with_the_previous_stages_settings(tmp_path, fault, hold):
    """The device's record: every frame a stage kept was exposed with that stage's exposure and
    gain. Without device time stamps (sim_wire's ares32 header) and without tags, the host cannot
    tell the frame in flight from a fresh one: it discards one frame after every register change,
    and the stage record on disk says so and why."""
    outcome, kept, truth, recs = _run(_scan(tmp_path, hold=hold), {fault: 1})
    for st, counters in zip(outcome.stages, kept):
        want = (pytest.approx(st["settings"]["exposure"]), st["settings"]["analog_gain"])
        got = [(truth[n]["exposure_s"], truth[n]["analog_gain"]) for n in counters]
        assert all(g == want for g in got), (st["name"], counters, got)
    for rec in recs:
        fl = rec["in_flight"]
        assert fl["discarded"] == 1 and fl["evidence"] == "none" and "in flight" in fl["why"], fl
        assert rec["discarded"] == 1  # (declared 0, and the frame in flight)
    # the device did deliver a frame exposed with the old settings after each change: it was dropped
    stale = [n for c in kept[1:] for n in [c[0] - 1] if truth[n]["analog_gain"] != truth[c[0]]["analog_gain"]]
    assert len(stale) == len(STAGES) - 1, (kept, truth)


@pytest.mark.parametrize("fault", ["usb_frame_in_flight", "usb_pipeline_frames"])
def test_device_time_stamps_tell_the_frame_in_flight(tmp_path, fault):
    """With the device's exposure-start time stamps (``header="ares40"``, on the bench's clock) the
    host discards exactly the frames that started before the commit -- the one streamed ahead (it
    started as the frame before was read out, before the I2C writes), the one exposed at the stop --
    and keeps the next: nothing fresh is wasted."""
    outcome, kept, truth, recs = _run(_scan(tmp_path, "ares40"), {fault: 1})
    for st, counters in zip(outcome.stages, kept):
        assert all(truth[n]["analog_gain"] == st["settings"]["analog_gain"] for n in counters), (st["name"], counters)
    for st, rec in zip(outcome.stages, recs):
        fl = rec["in_flight"]
        assert fl["evidence"] == "device timestamp" and fl["discarded"] == (0 if st["index"] == 0 else 1), fl


def test_the_direct_simulator_has_no_frame_in_flight(tmp_path):
    """The direct simulator exposes a frame when it is grabbed: its time stamps (exposure start on
    the bench's clock) show the first frame after the change started after it, so it is kept, and
    the stage's frames are those it always had (the first frame is the one looked at)."""
    outcome, kept, truth, recs = _run(_scan(tmp_path, sim=True), {})
    for rec in recs:
        fl = rec["in_flight"]
        assert fl["discarded"] == 0 and fl["kept"] == 1 and fl["evidence"] == "device timestamp", fl
    assert [k for k in kept] == [[0, 1, 2], [3, 4, 5], [6, 7, 8]]


LIGHTS = (1e5, 4e5, 2e5)  # photons/pixel/s: the light changes at every stage (exposure and gain stay)


def _light_scan(tmp_path: Path, header: str, timing: str = TIMED, quantity: str = "light",
                values: tuple = LIGHTS) -> Path:
    p = _scan(tmp_path, header)
    system = tmp_path / "sim_wire_48x64.xml"
    system.write_text(system.read_text().replace(TIMED, timing))
    stages = "\n".join(f'    <stage name="l{k}" scene="flat"><set quantity="{quantity}" value="{v:g}"/></stage>'
                       for k, v in enumerate(values))
    keep = '<set quantity="exposure" value="0.004"/><set quantity="analog_gain" value="2"/>'
    text = p.read_text().replace('<set quantity="light" value="2e5"/>',
                                 keep if quantity == "light" else keep + '<set quantity="light" value="2e5"/>')
    head, _, rest = text.partition("<stages>\n")
    p.write_text(head + "<stages>\n" + stages + "\n  </stages>" + rest.partition("</stages>")[2])
    return p


@pytest.mark.parametrize("header,fault,faults", [
    ("ares40", "usb_pipeline_frames", {"usb_pipeline_frames": 1}),
    ("ares40", "usb_frame_in_flight", {"usb_frame_in_flight": 1}),
    ("ares32", "usb_pipeline_frames", {"usb_pipeline_frames": 1, "light_tau_s": 0.002}),
], ids=["fifo_stamped", "streaming_stamped", "fifo_unstamped_ramp"])
def test_no_kept_frame_started_before_the_light_reached_its_level(tmp_path, header, fault, faults):
    """A stage that changes only the light, ``<settle by="time">``, no ``discard_frames``: the
    device's record -- the grabber's exposure start of every frame (``exposed_with``), the light
    source's time its output reached the new level (``changes``: commanded, then within its
    monitor's accuracy; with ``light_tau_s`` an LED relaxing over its time constant, the declared
    ``<after quantity="light" settle_s>`` covering it) -- shows no kept frame started exposing
    before that. A grabber that holds a frame exposed at its last stop (its FIFO) or a sensor
    exposing the next frame as one is read out delivers such a frame first after the change; the
    host discards it (by its time stamp, or one frame blind without one) and says so."""
    timing = TIMED if "light_tau_s" not in faults else TIMED.replace(
        '<settle by="time"/>', '<after quantity="light" settle_s="0.05"/><settle by="time"/>')
    outcome, kept, truth, light = _run_recorded(load_scan(_light_scan(tmp_path, header, timing)), faults, "led")
    assert outcome.status == "done", outcome.message
    assert [c["level"] for c in light] == list(LIGHTS)  # one change per stage, in order
    if "light_tau_s" in faults:  # the LED ramps: its output reached the level after the command
        assert all(c["settled_s"] > c["commanded_s"] for c in light[1:]), light
    early = {st["name"]: [(n, truth[n]["exposure_start_s"], change["settled_s"]) for n in kept[st["index"]]
                          if truth[n]["exposure_start_s"] < change["settled_s"] - 1e-9]
             for st, change in zip(outcome.stages, light)}
    assert not any(early.values()), early  # (stage: [(device counter, exposure start, light settled)])
    assert all(len(kept[st["index"]]) == 3 for st in outcome.stages)
    assert not [st["name"] for st in outcome.stages if st["settling"].get("unsettled")]  # (before: 'steps by +403 DN')
    for st in outcome.stages:
        fl = st["settling"]["flat"]["in_flight"]
        assert fl["evidence"] == ("device timestamp" if header == "ares40" else "none"), fl
        assert fl["discarded"] == (1 if st["index"] or header == "ares32" else 0) and "light" in fl["why"], fl


def test_no_kept_frame_started_before_the_chamber_reached_its_temperature(tmp_path):
    """The same at a temperature change (only the chamber's set point changes; the emulated
    chamber is there at once, its ``changes`` say when): the frame the grabber held from before
    is discarded by its time stamp, the record names the temperature change."""
    scan = load_scan(_light_scan(tmp_path, "ares40", quantity="temperature", values=(25, 30, 35)))
    outcome, kept, truth, chamber = _run_recorded(scan, {"usb_pipeline_frames": 1}, "chamber")
    assert outcome.status == "done", outcome.message
    assert [c["level"] for c in chamber] == [25, 30, 35]
    for st, change in zip(outcome.stages, chamber):
        starts = [truth[n]["exposure_start_s"] for n in kept[st["index"]]]
        assert len(starts) == 3 and min(starts) >= change["settled_s"] - 1e-9, (st["name"], starts, change)
    for st in outcome.stages[1:]:
        fl = st["settling"]["flat"]["in_flight"]
        assert fl["discarded"] == 1 and fl["evidence"] == "device timestamp" and "temperature change" in fl["why"], fl


@pytest.mark.parametrize("declared", [None, 2], ids=["depth_undeclared", "frames_in_flight_2"])
def test_a_pipeline_two_frames_deep_without_evidence(tmp_path, declared):
    """The simulator's sensor pipeline two frames deep (``pipeline_lag_frames=2``: the two frames after
    a register change are still exposed with the old settings -- the device's ``exposed_with``) behind
    an ``ares32`` grabber (no time stamps, no tags). Nothing tells which frames are stale, so the host
    discards as many as the device can hold in flight: one assumed when the system declares nothing --
    the second stale frame is then the stage's first kept frame -- and the declared
    ``<timing frames_in_flight="2">`` takes both; the record says how many and whence the number."""
    scan = _scan(tmp_path)
    if declared:
        system = tmp_path / "sim_wire_48x64.xml"
        system.write_text(system.read_text().replace("<timing ", f'<timing frames_in_flight="{declared}" ', 1))
        sy = load_scan(scan).system
        assert sy.timing.frames_in_flight == declared
        save_system(sy, tmp_path / "saved.xml")  # (written back as declared)
        assert load_system(tmp_path / "saved.xml").timing.frames_in_flight == declared
    outcome, kept, truth, recs = _run(scan, {"pipeline_lag_frames": 2})
    stale = {st["name"]: [n for n in counters if truth[n]["analog_gain"] != st["settings"]["analog_gain"]
                          or truth[n]["exposure_s"] != pytest.approx(st["settings"]["exposure"])]
             for st, counters in zip(outcome.stages, kept)}
    if declared is None:  # the device's truth: the frame right after the one discarded blind was stale
        assert stale == {"s0": [], "s1": [kept[1][0]], "s2": [kept[2][0]]}, (stale, kept)
    else:
        assert not any(stale.values()), (stale, kept)
    n = declared or 1
    for rec in recs:
        fl = rec["in_flight"]
        assert fl["evidence"] == "none" and fl["discarded"] == fl["frames_in_flight"] == n == rec["discarded"], fl
        assert fl["depth"] == ("declared" if declared else "assumed") and "in flight" in fl["why"], fl


def test_a_declared_discard_below_the_declared_depth_takes_the_depth(tmp_path):
    """``discard_frames="1"`` with ``frames_in_flight="2"`` on the two-frame-deep pipeline: a declared
    discard is trusted to take the frame in flight, but one fewer than the declared depth would keep
    the second stale frame (the device's ``exposed_with``); the depth wins and the record says why."""
    scan = _scan(tmp_path)
    system = tmp_path / "sim_wire_48x64.xml"
    system.write_text(system.read_text().replace("<timing ", '<timing frames_in_flight="2" discard_frames="1" ', 1))
    outcome, kept, truth, recs = _run(scan, {"pipeline_lag_frames": 2})
    for st, counters in zip(outcome.stages, kept):
        assert all(truth[n]["analog_gain"] == st["settings"]["analog_gain"] for n in counters), (st["name"], counters)
    assert recs and all(r["discarded"] == 2 and "frames_in_flight" in r["why_discarded"] for r in recs), recs


@pytest.mark.parametrize("value", ["0", "17", "two"])
def test_a_bad_frames_in_flight_names_the_file_and_line(tmp_path, value):
    system = tmp_path / "sim_wire_48x64.xml"
    _scan(tmp_path)
    text = system.read_text()
    system.write_text(text.replace("<timing ", f'<timing frames_in_flight="{value}" ', 1))
    line = text[:text.index("<timing ")].count("\n") + 1
    with pytest.raises(InputError, match=rf"{system.name}:{line}: <timing frames_in_flight"):
        load_system(system)


MONO = """    <monochromator name="cs130" port="aresemu://cs130" baud="9600" timeout_s="2" min="250" max="1100" unit="nm">
      <protocol terminator="\\r\\n" reply_terminator="\\n" error="ERR\\s*(?P&lt;text&gt;.*)">
        <command name="set" send="GOWAVE {value:.2f}" reply="OK"/>
        <command name="get" send="WAVE?" reply="(?P&lt;value&gt;\\S+)"/>
        <command name="bandwidth" send="BANDPASS?" reply="(?P&lt;value&gt;\\S+)"/>
        <command name="complete" send="*OPC?" reply="1" timeout_s="30"/>
      </protocol>
    </monochromator>
  </devices>"""
QE = ('<param name="qe_curve_nm" type="floats" value="400 500 600 700"/>'
      '<param name="qe_curve" type="floats" value="0.40 0.70 0.60 0.30"/>')


@pytest.mark.parametrize("header", ["ares40", "ares32"])
def test_no_kept_frame_was_exposed_at_the_previous_wavelength(tmp_path, header):
    """A stage that changes only the monochromator's wavelength changes the light on the sensor
    (its QE there): the grabber holding a frame exposed at its last stop (``usb_pipeline_frames=1``)
    delivers it first. The device's record of each frame's light (``exposed_with``: the photon flux
    it was rendered with, the QE at the wavelength then) shows no kept frame of the old wavelength;
    the frame is discarded by its time stamp (``ares40``) or blind (``ares32``), the record names
    the wavelength change. (The monochromator answers ``*OPC?`` when its grating has stopped:
    ``test_source_settled`` shows the frames exposed while it moves are not kept.)"""
    scan = _light_scan(tmp_path, header, quantity="wavelength", values=(450, 550, 650))
    system = tmp_path / "sim_wire_48x64.xml"
    text = system.read_text().replace("  </devices>", MONO, 1)
    system.write_text(text.replace('<simulator seed="1" wire="true">', '<simulator seed="1" wire="true">' + QE, 1))
    outcome, kept, truth, recs = _run(scan, {"usb_pipeline_frames": 1})
    flux = [{truth[n]["photon_flux"] for n in counters} for counters in kept]
    assert all(len(f) == 1 for f in flux) and len(set.union(*flux)) == 3, (kept, flux)  # one light per stage, each its own
    for st, rec in zip(outcome.stages[1:], recs[1:]):
        fl = rec["in_flight"]
        assert fl["discarded"] == 1 and "wavelength change" in fl["why"], fl
        assert fl["evidence"] == ("device timestamp" if header == "ares40" else "none"), fl
        assert truth[kept[st["index"]][0] - 1]["photon_flux"] not in flux[st["index"]]  # the one dropped: the old light


def test_the_frame_in_flight_integrates_the_light_of_its_own_exposure(tmp_path, monkeypatch):
    """A streaming sensor's frame in flight (``usb_frame_in_flight=1``) started exposing as the one
    before was read out; the light changed during its exposure. The device renders it with the light
    that fell on it -- the time-weighted mix over its own exposure window, by the device's records
    (its exposure start, the light's commanded time, the exposure) -- not with the new light its
    read-out comes under: the host that kept it would keep a frame of the wrong light."""
    from ares.scan import in_flight

    scan = load_scan(_light_scan(tmp_path, "ares40"))
    outcome, kept, truth, light = _run_recorded(scan, {"usb_frame_in_flight": 1}, "led")
    assert outcome.status == "done", outcome.message
    mixed = 0
    for st, before, change in zip(outcome.stages[1:], light, light[1:]):
        n = kept[st["index"]][0] - 1  # the frame discarded: in flight at the change
        rec, exp = truth[n], truth[n]["exposure_s"]
        new = min(max((rec["exposure_start_s"] + exp - change["commanded_s"]) / exp, 0.0), 1.0)
        want = before["level"] * (1 - new) + change["level"] * new
        assert rec["photon_flux"] == pytest.approx(want, rel=1e-9), (rec, change, new)
        assert abs(rec["photon_flux"] - change["level"]) > 0.5 * abs(change["level"] - before["level"]), rec
        mixed += 0 < new < 1
        assert all(truth[k]["photon_flux"] == change["level"] for k in kept[st["index"]])
    assert mixed == 2  # (here the change falls inside the frame's exposure, near its end: mostly old light)
    monkeypatch.setattr(in_flight, "judge", lambda *a, **k: (True, "device timestamp"))  # a host that keeps it
    outcome, kept, truth, light = _run_recorded(load_scan(_light_scan(tmp_path, "ares40")), {"usb_frame_in_flight": 1},
                                                "led")
    for st, change in zip(outcome.stages[1:], light[1:]):
        first = truth[kept[st["index"]][0]]["photon_flux"]
        assert abs(first - change["level"]) > 0.5 * abs(change["level"] - light[st["index"] - 1]["level"]), first


def test_time_stamps_do_not_prove_the_settings_a_frame_latched(tmp_path):
    """A sensor whose registers take effect two frames late (``pipeline_lag_frames=2``, declared
    ``<timing frames_in_flight="2">``) behind an ``ares40`` grabber: every frame after the write
    started after it (its time stamp), yet the first two carry the old settings (the device's
    ``exposed_with``). The time stamps called them fresh and two of each stage's three kept
    frames were stale; a time stamp tells when a frame started, not what it latched, so the
    declared depth's frames go unless tags prove them."""
    scan = _scan(tmp_path, header="ares40", hold=False)
    system = tmp_path / "sim_wire_48x64.xml"
    system.write_text(system.read_text().replace("<timing ", '<timing frames_in_flight="2" ', 1))
    outcome, kept, truth, recs = _run(scan, {"pipeline_lag_frames": 2})
    for st, counters in zip(outcome.stages, kept):
        assert all(truth[n]["analog_gain"] == st["settings"]["analog_gain"] for n in counters), (st["name"], counters)
    for rec in recs:
        fl = rec["in_flight"]
        assert fl["evidence"] == "device timestamp" and fl["discarded"] == 2 and "latched" in fl["why"], fl


def test_a_declared_depth_the_device_time_stamps_contradict_is_named():
    """Two frames stamped before the change where the system declares one in flight: both go
    (their time stamps), and the record names the declaration they contradict -- on a device
    that tells nothing the declared depth would keep the second."""
    import numpy as np

    from ares.hardware.interfaces import Frame
    from ares.scan.in_flight import drop_in_flight

    class Src:
        name, shape, bit_depth = "stamped", (2, 2), 12

        def __init__(self):
            self.t = iter([0.9, 0.95, 1.2, 1.3])

        def grab(self, n):
            for _ in range(n):
                yield Frame(np.zeros((2, 2), np.uint16), meta={"device_timestamp_s": next(self.t)})

    class Bench:
        clock = object()

        def __init__(self):
            self.frames = Src()

    rec = drop_in_flight(Bench(), {}, False, 1.0, "light change", depth=1)
    assert rec["discarded"] == 2 and rec["kept"] == 1 and rec["depth_exceeded"] == {"declared": 1, "seen": 2}, rec
    assert 'frames_in_flight="2"' in rec["why"], rec
    ok = drop_in_flight(Bench(), {}, False, 1.0, "light change", depth=2)
    assert ok["discarded"] == 2 and "depth_exceeded" not in ok, ok
