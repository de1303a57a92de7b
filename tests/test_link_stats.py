"""Link statistics and device identities in the run (issue 36, finding 9) on
protocols/sim_wire.xml (at 48x64 pixels): each stage's USB/I2C/serial counts in its JSON and HDF5 (with unit
attributes), the totals and what each device said it is in run.json, both in the terminal
summary and on the report's first page. Before the change none of it reached the run
directory. Counts are checked against the USB packet rules and the injected faults."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import pytest

from ares.cli import main
from wire_small import COLS, ROWS, small_wire

FRAME_BYTES = 32 + COLS * ROWS * 3 // 2  # ares32 header + Mono12p payload: 9 whole 512-byte packets
FRAMES = 2


def _scan(tmp_path: Path) -> Path:
    p = tmp_path / "link.xml"
    p.write_text(f"""<?xml version="1.0"?>
<scan name="link" version="1">
  <system href="{small_wire(tmp_path)}"/>
  <settings><set quantity="exposure" value="0.01"/></settings>
  <frames>{FRAMES}</frames>
  <stages>
    <stage name="dark" scene="dark"/>
    <sweep name="ptc" scene="flat"><axis quantity="light"><values>1e4 1e5</values></axis></sweep>
  </stages>
  <output pdf="false"/>
</scan>
""")
    return p


def _stages(out: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((out / "stages").glob("[0-9][0-9][0-9][0-9].json"))]


def _run(tmp_path, name, *faults, capsys=None) -> tuple[int, Path, str]:
    out = tmp_path / name
    rc = main(["run", str(_scan(tmp_path)), "--out", str(out), *[a for f in faults for a in ("--sim-fault", f)]])
    text = capsys.readouterr().out if capsys is not None else ""
    return rc, out, text


def test_link_counts_per_stage_follow_the_packet_rules_and_add_up(tmp_path, capsys):
    rc, out, text = _run(tmp_path, "clean", capsys=capsys)
    assert rc == 0
    stages, meta = _stages(out), json.loads((out / "run.json").read_text())
    for st in stages:
        with h5py.File(out / "stages" / f"{st['index']:04d}.h5") as f:  # the frames the stage grabbed
            n = sum(len(f[k]) for k in ("frame_counter", "dark_frame_counter") if k in f)
        # and the frames settling took before them (ares.scan.settling: the stage record says how many)
        recs = [r for r in st.get("settling", {}).values() if isinstance(r, dict) and "changed" in r]
        probes = sum(r.get("probe_frames", 0) for r in recs)  # one grab each
        n += probes + sum(r.get("discarded", 0) for r in recs)
        usb = st["link"]["frames"]
        assert usb["bytes"] == n * FRAME_BYTES
        assert usb["short_packets"] == n  # header_packet="own": each header is a short packet of its own
        # each payload is whole packets: a ZLP ends it (a grab's last one is dropped at its stop)
        assert n - 2 - probes <= usb["zlps"] <= n
        assert usb["timeouts"] == usb["overflows"] == usb["resyncs"] == usb["dropped_frames"] == 0
        assert st["link"]["registers"]["nack_retries"] == 0 and st["link"]["registers"]["transactions"] > 0
        with h5py.File(out / "stages" / f"{st['index']:04d}.h5") as f:
            assert int(f["link_frames_bytes"][()]) == usb["bytes"] and f["link_frames_bytes"].attrs["unit"] == "bytes"
            assert f["link_registers_transactions"].attrs["unit"] == "1 (count during the stage)"
            assert int(f["link_light_commands"][()]) == st["link"]["light"]["commands"]
    total = meta["link"]
    assert total["frames"]["bytes"] == sum(st["link"]["frames"]["bytes"] for st in stages)
    # the chip-ID read and the <init> write at connect, then every transaction inside a stage
    assert total["registers"]["transactions"] == 2 + sum(st["link"]["registers"]["transactions"] for st in stages)
    assert total["light"]["commands"] == 1 + sum(st["link"]["light"]["commands"] for st in stages)  # *IDN? at open
    dev = meta["devices"]
    assert dev["registers"] == {"interface": "I2C", "bus": 1, "address": "0x36", "chip_id": "0xa2e5", "name": "sensor"}
    assert dev["frames"]["vid_pid"] == "1d50:6a5e" and dev["frames"]["serial"] == "ARES-EMU-0001"
    assert dev["light"]["idn"] == "ARES,EMULATED-LED,0,1.0" and dev["chamber"]["idn"] == "ARES,EMULATED-CHAMBER,0,1.0"
    assert "registers: sensor (I2C): bus 1, address 0x36, chip id 0xa2e5" in text
    assert "frames: grabber (USB): vid pid 1d50:6a5e, serial ARES-EMU-0001" in text
    assert "light: led (serial): port aresemu://led, idn ARES,EMULATED-LED,0,1.0" in text
    assert f"frames link: {total['frames']['transfers']} transfers, {total['frames']['bytes']} bytes" in text

    from ares.report.pdf import title_page
    from ares.report.source import read_run

    from ares.rundir.check import RunDamaged, check_run

    check_run(out, meta, stages)  # issue 37's records cover the link scalars too
    with h5py.File(out / "stages" / "0001.h5", "r+") as f:
        f["link_frames_timeouts"][()] = 7
    with pytest.raises(RunDamaged, match=r"stage 1 \('ptc\[0\]'\): array 'link_frames_timeouts' of stages/0001.h5 "
                                         "differs from the SHA-256"):
        check_run(out, meta, stages)
    fig = title_page(read_run(out), {})
    page = " ".join(t.get_text() for t in fig.texts)
    assert "sensor (I2C): bus 1, address 0x36, chip id 0xa2e5" in page and "ARES-EMU-0001" in page
    assert f"{total['registers']['transactions']} transactions" in page


def test_retries_are_counted_in_the_stage_they_happened(tmp_path, capsys):
    _, clean, _ = _run(tmp_path, "clean")
    base = [st["link"]["registers"]["transactions"] for st in _stages(clean)]
    first = 2 + base[0]  # the first I2C transaction of stage 1
    rc, out, _ = _run(tmp_path, "faulty", f"i2c_nack_at={first}", f"i2c_busy_at={first + 3}", "usb_garbage_at=3",
                      capsys=capsys)
    assert rc == 0
    stages = _stages(out)
    regs = [st["link"]["registers"] for st in stages]
    assert [r["nack_retries"] for r in regs] == [0, 1, 0] and [r["busy_retries"] for r in regs] == [0, 1, 0]
    assert [r["transactions"] for r in regs] == [base[0], base[1] + 2, base[2]]  # each retry is a transaction
    assert sum(st["link"]["frames"]["resyncs"] for st in stages) == 1  # the garbage before frame 3 was skipped


def test_a_failed_run_records_the_link_counts_that_failed_it(tmp_path, capsys):
    rc, out, _ = _run(tmp_path, "timeout", "usb_timeout_at=3", capsys=capsys)
    assert rc == 3
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "failed" and meta["link"]["frames"]["timeouts"] == 1
    assert meta["devices"]["registers"]["chip_id"] == "0xa2e5"
