"""The simulated sensor behind emulated I2C, USB and serial devices (protocols/sim_wire.xml):
same frames as the direct simulator, every injected fault a one-sentence error with the
completed stages kept, lost frames re-grabbed when the scan says so."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

from ares.cli import main
from ares.errors import DeviceGone, HardwareError
from ares.rig.factory import build_bench
from ares.protocol import load_system

ROOT = Path(__file__).resolve().parents[1]
WIRE = ROOT / "protocols" / "sim_wire.xml"


def _short_scan(tmp_path: Path, frames_attrs: str = "") -> Path:
    """dark, three light levels, one chamber set point: 5 stages of 2 frames (device frame
    counter 0..14: the frame in flight at each stage's change is discarded -- sim_wire's ares32
    header tells no exposure start -- so ptc[1] keeps frames 7, 8; light commands after the
    identity: a set point, the check that the output is there (MON?, ``ares.scan.source_settled``)
    and its readback (MON?) per stage; chamber commands from stage 5), on
    sim_wire.xml with the declared waits only (``<settle by="time">``: no probe frames)."""
    p = tmp_path / "wire_short.xml"
    timed = tmp_path / "sim_wire_timed.xml"  # the faults are placed by device frame: the declared waits only
    timed.write_text(WIRE.read_text().replace('<timing readout_s="0.001" settle_s="0"/>',
                                              '<timing readout_s="0.001" settle_s="0"><settle by="time"/></timing>'))
    p.write_text(f"""<?xml version="1.0"?>
<scan name="wire_short" version="1">
  <system href="{timed}"/>
  <settings><set quantity="exposure" value="0.01"/></settings>
  <frames{frames_attrs}>2</frames>
  <stages>
    <stage name="dark" scene="dark"/>
    <sweep name="ptc" scene="flat"><axis quantity="light"><values>1e4 1e5 1e6</values></axis></sweep>
    <stage name="warm" scene="dark"><set quantity="temperature" value="30"/></stage>
  </stages>
  <output pdf="false"/>
</scan>
""")
    return p


def _run(scan, out, *extra) -> int:
    return main(["run", str(scan), "--out", str(out), "-q", *extra])


def test_wire_frames_bit_identical_to_direct_simulator():
    """Register writes over I2C, light over serial, frames over USB (Mono12p, header, CRC):
    the same frames as the direct bench with the same seed, at several operating points."""
    wire, direct = build_bench(load_system(WIRE), seed=5), build_bench(load_system(ROOT / "protocols" /
                                                                                   "sim_sensor.xml"), seed=5)
    try:
        for exposure, light, mode in ((0.01, 0.0, 1), (0.003, 2.5e5, 0), (0.02, 123456.789, 0), (0.01, 0, 2)):
            got = []
            for b in (wire, direct):
                b.registers.set("exposure", exposure)
                b.registers.set("test_mode", mode)
                b.light.set_level(light)
                got.append([f.data for f in b.frames.grab(5)])
            assert all(np.array_equal(x, y) for x, y in zip(*got))
        assert wire.frames.stats() == {"frames": 20, "dropped": 0, "corrupt": 0, "short": 0, "resyncs": 0,
                                       "skipped_bytes": 0}
        grabber = wire.emulators["usb"]
        starts = [r for r in grabber.requests if r[1] == 0xB1]
        assert [r[2] for r in starts] == [5, 5, 5, 5]  # 'start' carried the frame count
        assert grabber.requests[0][1] == 0xA0  # the 'open' request came first
        assert wire.registers.get("chip_id") == 0xA2E5 and wire.light.identify().startswith("ARES")
    finally:
        wire.close()
        direct.close()


def test_photon_transfer_scan_through_the_wires_equals_direct(tmp_path):
    """The issue's check: `ares run scans/photon_transfer.xml --system protocols/sim_wire.xml
    --seed 1` gives the direct simulator's stage results, arrays and key figures."""
    text = (ROOT / "scans" / "photon_transfer.xml").read_text()
    for a, b in (('href="../protocols/sim_sensor.xml"', f'href="{ROOT / "protocols" / "sim_sensor.xml"}"'),
                 ('pdf="true"', 'pdf="false"')):  # (stages, arrays and key_figures.csv compared, not the PDF)
        assert a in text
        text = text.replace(a, b)
    scan = tmp_path / "photon_transfer.xml"
    scan.write_text(text)
    assert _run(scan, tmp_path / "wire", "--system", str(WIRE), "--seed", "1") == 0
    assert _run(scan, tmp_path / "direct", "--seed", "1") == 0
    a, b = tmp_path / "wire" / "stages", tmp_path / "direct" / "stages"
    names = sorted(p.name for p in a.glob("*.json"))
    assert names == sorted(p.name for p in b.glob("*.json")) and len(names) == 26
    for n in names:
        ja, jb = (json.loads((d / n).read_text()) for d in (a, b))
        for j in (ja, jb):  # the frame timestamps differ by design (host time vs model clock): so do
            j.pop("h5_bytes", None)  # the stage file's size and the timestamps' hashes
            for k in [k for k in j.get("arrays_sha256", {}) if k.endswith("frame_timestamp")]:
                del j["arrays_sha256"][k]
        assert ja.pop("link")["frames"]["transfers"] > 0 and "link" not in jb  # only wires have link statistics
        ha, hb = ja.pop("arrays_sha256", {}), jb.pop("arrays_sha256", {})
        assert {k: ha[k] for k in ha if k in hb} == {k: hb[k] for k in hb if k in ha}, n  # same arrays, same bytes
        for j in (ja, jb):
            j.pop("timing"), j.pop("bench_position", None)  # wall time; the simulator's stream position
            light = j.get("setpoints", {}).get("light", {})  # the wire's LED tolerance is the XML's
            light.pop("tolerance", None), light.pop("ok", None)  # tolerance=, the simulator's its monitor's
            for rec in j.get("settling", {}).values():  # the simulator tags its frames, the wires do not:
                if isinstance(rec, dict):  # the same frames, the same decision, by other evidence
                    rec.pop("by", None)
                    if j is ja and "registers" in rec:  # sim_wire.xml declares its sensor's group hold:
                        assert rec.pop("registers")["atomic"] is True, n  # a stage's writes latch together
                    rec.pop("registers", None)  # (the direct simulator's are set at once, before the frame)
        for ra, rb in ((ra, jb["settling"][w]) for w, ra in ja.get("settling", {}).items() if isinstance(ra, dict)):
            pa, pb = ra.pop("probe_s", 0.0), rb.pop("probe_s", 0.0)  # the wires' I2C takes its bus time
            assert pb <= pa <= pb + 0.01, (n, pa, pb)  # on the bench's clock (the direct registers take none)
        assert ja == jb, (n, {k for k in ja.get("arrays_sha256", {}) if ja["arrays_sha256"][k] != jb.get("arrays_sha256", {}).get(k)}, {k for k in ja if ja[k] != jb.get(k)})
        with h5py.File(a / n.replace(".json", ".h5")) as fa, h5py.File(b / n.replace(".json", ".h5")) as fb:
            keys = []
            fa.visit(keys.append)
            for k in keys:
                if k.endswith("frame_timestamp") or k.startswith("link_"):  # host time at arrival vs the
                    continue  # simulator's model clock; the wires' link statistics
                if isinstance(fa[k], h5py.Dataset):
                    assert np.array_equal(fa[k][()], fb[k][()]), (n, k)
    assert (tmp_path / "wire" / "key_figures.csv").read_text() == (tmp_path / "direct" / "key_figures.csv").read_text()


def _i2c_transactions_at_stage(tmp_path, stage: int) -> int:
    """How many I2C transactions a clean run of the short scan makes before stage ``stage``."""
    from ares.protocol import load_scan
    from ares.scan import Runner
    from ares.scan import events as ev

    scan = load_scan(_short_scan(tmp_path))
    bench = build_bench(scan.system, seed=1)
    seen = {}
    runner = Runner(scan, bench=bench, listeners=(lambda e: seen.setdefault(e.index, bench.emulators["i2c"]
                                                                               .transactions)
                                                  if isinstance(e, ev.StageStarted) else None,))
    try:
        assert runner.run().status == "done"
    finally:
        bench.close()
    return seen[stage]


FAULTS = [  # (faults, what the sentence must say, completed stages); serial command 0 is *IDN? at open
    (["usb_drop_at=7"], r"grabber.*1 frame\(s\) dropped before frame 7", 2),
    (["usb_corrupt_at=7"], r"grabber.*frame 7 \(device counter 7\) is corrupt \(payload CRC mismatch\)", 2),
    (["usb_short_at=7"], r"grabber.*frame 7 .* arrived short \(230432 of 460832 bytes\)", 2),
    (["usb_timeout_at=7"], r"grabber.*no data on endpoint 0x81 within 2000 ms \(timeout\)", 2),
    (["usb_disconnect_at=7"], r"grabber.*device disconnected", 2),
    (["light_timeout_at=7"], r"led on aresemu://led: no reply to 'LEVEL 100000.0' within 1 s", 2),
    (["light_wrong_reply_at=7"], r"led on aresemu://led: reply '\?#%' to 'LEVEL 100000.0' does not match 'OK'", 2),
    (["light_error_at=7"], r"led on aresemu://led: refused 'LEVEL 100000.0': emulated fault", 2),
    (["light_disconnect_at=7"], r"led on aresemu://led: port error", 2),
    (["chamber_timeout_at=1"], r"chamber on aresemu://chamber: no reply to 'TEMP 30.0'", 4),
    (["chamber_wrong_reply_at=2"], r"chamber on aresemu://chamber: reply '\?#%' to 'TEMP\?' is not a number", 4),
    ("i2c_nack", r"I2C device 0x36 on bus 1 \('sensor'\), register 0x[0-9a-f]{4}: no acknowledge on (read|write) "
                 r"after 3 attempt\(s\).*\(field '\w+'\)", 2),
    ("i2c_timeout", r"I2C device 0x36 on bus 1 \('sensor'\), register 0x[0-9a-f]{4}: timeout on (read|write) "
                    r"after 3 attempt\(s\)", 2),
    ("i2c_disconnect", r"I2C device 0x36 on bus 1 \('sensor'\), register 0x[0-9a-f]{4}: device gone", 2),
]


@pytest.mark.parametrize("faults,sentence,completed", FAULTS, ids=[str(f[0]) for f in FAULTS])
def test_every_fault_is_one_sentence_with_the_stages_kept(tmp_path, capsys, faults, sentence, completed):
    scan = _short_scan(tmp_path)
    if isinstance(faults, str):  # I2C: the transaction count where stage 3 begins
        n = _i2c_transactions_at_stage(tmp_path, 2) + 1
        faults = {"i2c_nack": [f"i2c_nack_at={n}", "i2c_fault_count=3"],
                  "i2c_timeout": [f"i2c_timeout_at={n}", "i2c_fault_count=3"],
                  "i2c_disconnect": [f"i2c_disconnect_at={n}"]}[faults]
    out = tmp_path / "run"
    rc = _run(scan, out, *[a for f in faults for a in ("--sim-fault", f)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 3
    assert len(err) == 1 and re.search(sentence, err[0]), err
    assert f"{completed} completed stage(s) saved in {out}" in err[0]
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "failed" and meta["stages_completed"] == completed
    for k in range(completed):  # each completed stage is whole and readable
        assert json.loads((out / "stages" / f"{k:04d}.json").read_text())["index"] == k
        with h5py.File(out / "stages" / f"{k:04d}.h5") as f:
            assert len(f.keys()) > 0
    assert not (out / "stages" / f"{completed:04d}.json").exists()


def test_a_retry_absorbs_one_nack_and_garbage_is_skipped(tmp_path, capsys):
    """One NACK or timeout is retried; junk bytes before a frame are skipped (resync)."""
    n = _i2c_transactions_at_stage(tmp_path, 2) + 1
    out = tmp_path / "run"
    assert _run(_short_scan(tmp_path), out, "--sim-fault", f"i2c_nack_at={n}", "--sim-fault",
                f"i2c_timeout_at={n + 5}", "--sim-fault", "usb_garbage_at=3") == 0
    assert json.loads((out / "run.json").read_text())["status"] == "done"


def test_dropped_frame_regrabs_the_stage_when_the_scan_says_so(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(_short_scan(tmp_path, ' on_loss="regrab"')), "--out", str(out), "--sim-fault",
                 "usb_drop_at=7"]) == 0
    assert "frames lost: dropped 1; stage(s) ptc[1] acquired again" in capsys.readouterr().out
    st = json.loads((out / "stages" / "0002.json").read_text())
    assert st["frames_lost"] == [{"kind": "dropped", "count": 1, "message": st["frames_lost"][0]["message"]}]
    assert "frame counter jumped from 6 to 8" in st["frames_lost"][0]["message"]
    assert "frames_lost" not in json.loads((out / "stages" / "0001.json").read_text())
    assert json.loads((out / "run.json").read_text())["stages_completed"] == 5


def test_regrab_limit_then_fail(tmp_path, capsys):
    out = tmp_path / "run"
    rc = _run(_short_scan(tmp_path, ' on_loss="regrab" max_regrabs="0"'), out, "--sim-fault", "usb_corrupt_at=7")
    assert rc == 3
    assert "still losing frames after 0 re-grab(s)" in capsys.readouterr().err


def test_unplugged_grabber_is_found_again_by_serial():
    """A disconnect, then the device re-enumerates: reconnect() finds it by VID/PID/serial."""
    b = build_bench(load_system(WIRE), seed=1, faults={"usb_disconnect_at": 1, "usb_reconnect_after_polls": 2})
    try:
        it = b.frames.grab(3)
        next(it)
        with pytest.raises(DeviceGone, match="disconnected"):
            next(it)
        with pytest.raises(DeviceGone, match="serial number ARES-EMU-0001 is not connected"):
            b.reconnect()
        b.reconnect()
        assert len(list(b.frames.grab(2))) == 2
    finally:
        b.close()


def test_grabber_picked_by_serial_and_two_adc_wire_order():
    """Two grabbers on one bus: the XML's serial picks one. A 2-ADC sensor sending each row
    ADC by ADC (wire_order='channel_rows') is put back in image order."""
    from ares.hardware.emulators.usb_backend import EmulatedUsbBackend
    from ares.hardware.emulators.usb_device import EmulatedGrabber
    from ares.hardware.interfaces import Frame
    from ares.hardware.usb import UsbFrameSource

    img = np.arange(8 * 12, dtype=np.uint16).reshape(8, 12) * 7

    class Pattern:
        def grab(self, n):
            for k in range(n):
                yield Frame(img + k, k)

    cfg = dataclasses.replace(load_system(WIRE).usb_grabber, format="mono10p", wire_order="channel_rows")
    other = EmulatedGrabber(Pattern(), cfg, serial="OTHER")
    mine = EmulatedGrabber(Pattern(), cfg, channels=2, interleave="column", serial="ARES-EMU-0001")
    src = UsbFrameSource.open(cfg, img.shape, 10, backend=EmulatedUsbBackend([other, mine]), channels=2,
                              interleave="column")
    frames = [f.data for f in src.grab(3)]
    assert all(np.array_equal(f, img + k) for k, f in enumerate(frames))
    assert other.counter == 0 and mine.counter == 3
    assert [f.meta for f in src.grab(1)] == [{"counter": 3}]


def test_watchdog_ends_a_trickling_frame():
    """Data that keep coming, each read within the timeout, but never a whole frame."""
    import time

    from ares.hardware.emulators.usb_backend import EmulatedUsbBackend
    from ares.hardware.emulators.usb_device import EmulatedGrabber
    from ares.hardware.usb import UsbFrameSource

    class Trickle(EmulatedGrabber):  # a full-speed device: 64-byte packets
        def bulk_read(self, endpoint, size, timeout_ms=None):
            time.sleep(0.01)
            return super().bulk_read(endpoint, min(size, 64), timeout_ms)

    sy = load_system(WIRE)
    cfg = dataclasses.replace(sy.usb_grabber, watchdog_ms=100, chunk_bytes=64)
    dev = build_bench(load_system(ROOT / "protocols" / "sim_sensor.xml"), seed=1)
    src = UsbFrameSource.open(cfg, (480, 640), 12, backend=EmulatedUsbBackend([Trickle(dev.frames, cfg, max_packet=64)]))
    with pytest.raises(HardwareError, match=r"grabber.*watchdog: frame 0 not complete within 100 ms"):
        next(src.grab(1))


def test_image_row_readback_for_a_sensor_without_i2c_read():
    """readback='image_row': reads NACK on the bus, the registers come from image row 0."""
    sy = load_system(WIRE)
    bus = dataclasses.replace(sy.buses[0], readback="image_row", readback_row=0, readback_start=0, verify=False)
    b = build_bench(dataclasses.replace(sy, buses=(bus,)), seed=1)
    try:
        assert b.registers.get("chip_id") == 0xA2E5
        b.registers.set("exposure", 0.0123)
        assert b.registers.get("exposure") == pytest.approx(0.0123)
        assert b.registers.get("analog_gain") == 1.0
        # the chip-ID check at connect, then one frame after each write (the <init> write, exposure), then cached
        assert b.registers.bus.readback.frames_used == 3
    finally:
        b.close()
