"""Run directory: layout, provenance, and what survives a SIGKILL."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from ares.errors import InputError
from ares.protocol import load_scan
from ares.scan import Runner, load_run, scan_level_results
from ares.rundir.files import sha256

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("rd") / "run"
    out = Runner(load_scan(SMALL / "ptc_small.xml"), out_dir=d, argv=["run", "x"]).run()
    assert out.status == "done"
    return d


def test_layout_and_provenance(run_dir):
    meta = json.loads((run_dir / "run.json").read_text())
    assert meta["status"] == "done" and meta["stages_completed"] == meta["stages_total"] == 9
    assert meta["seed"] == 7 and meta["argv"] == ["run", "x"]
    assert meta["versions"]["numpy"] and meta["versions"]["h5py"] and meta["versions"]["python"]
    for key in ("scan", "system"):
        p = run_dir / meta[f"{key}_file"]
        src = Path(meta[f"{key}_source"])
        assert p.read_bytes() == src.read_bytes()  # verbatim
        assert sha256(p.read_bytes()) == meta[f"{key}_sha256"]
    st = json.loads((run_dir / "stages" / "0003.json").read_text())
    assert st["settings"]["light"] > 0 and st["registers_before"]["chip_id"] == 0xA2E5
    assert st["registers_after"]["exposure"] == pytest.approx(0.01)
    comp = st["views"]["full"]["components"]["Pt"]
    assert comp["value"] > 0 and comp["se"] > 0 and comp["unit"] == "DN^2"
    assert set(st["views"]) == {"full", "centre", "adc0", "adc1"}
    res = json.loads((run_dir / "scan_results.json").read_text())
    assert res["analyses"]["ptc"]["gain_dn_per_e"]["value"] > 0 and res["limit_failures"] == []


def test_hdf5_csv_and_frames(run_dir):
    with h5py.File(run_dir / "results.h5", "r") as f:
        assert sorted(f["stages"]) == [f"{i:04d}" for i in range(9)]
        g = f["stages/0004"]
        assert g["mean"].shape == (24, 32) and g["variance"].shape == (24, 32) and g["frame_means"].shape == (4,)
        assert "dark_mean" in g and json.loads(g.attrs["result"])["name"] == "ptc[3]"
        assert f["stages"].get("0004", getlink=True).filename == "stages/0004.h5"  # index of external links
    rows = list(csv.DictReader((run_dir / "summary.csv").open()))
    assert len(rows) == 9 and rows[4]["name"] == "ptc[3]" and float(rows[4]["light_photons_per_pixel_per_s"]) > 0
    with h5py.File(run_dir / "frames" / "0001.h5", "r") as f:  # scan asks for raw frames
        assert f["frames"].shape == (4, 24, 32) and f["frames"].chunks == (1, 24, 32)
        assert f["frames"].dtype.kind == "u"
    assert not list(run_dir.rglob("*.tmp")) and not list(run_dir.rglob("*.partial"))


def test_load_run_and_scan_level_results_from_directory(run_dir):
    rec = load_run(run_dir)
    assert rec.scan.name == "ptc_small" and len(rec.stages) == 9
    assert rec.arrays(2)["mean"].shape == (24, 32)
    again = scan_level_results(rec)
    saved = json.loads((run_dir / "scan_results.json").read_text())["analyses"]
    assert again["ptc"]["gain_dn_per_e"]["value"] == pytest.approx(saved["ptc"]["gain_dn_per_e"]["value"])


def test_tampered_xml_is_refused(run_dir, tmp_path):
    import shutil

    d = tmp_path / "copy"
    shutil.copytree(run_dir, d)
    p = d / json.loads((d / "run.json").read_text())["scan_file"]
    p.write_bytes(p.read_bytes().replace(b"<frames>4</frames>", b"<frames>5</frames>"))
    with pytest.raises(InputError, match="SHA-256 differs"):
        load_run(d)
    with pytest.raises(InputError, match="not an ARES run directory"):
        load_run(tmp_path)


def test_output_dir_must_be_empty(run_dir):
    with pytest.raises(InputError, match="not empty"):
        Runner(load_scan(SMALL / "ptc_small.xml"), out_dir=run_dir).run()


CHILD = r"""
import sys, time
from ares.protocol import load_scan
from ares.scan import Runner, events as ev
import threading
k, where = int(sys.argv[2]), sys.argv[3]
r = Runner(load_scan(sys.argv[1]), out_dir=sys.argv[4])
committed = threading.Event()  # stage k-1 is committed beside stage k's frames (ares.scan.commit)
def hold(e):
    if isinstance(e, ev.StageFinished) and e.index == k - 1:
        committed.set()
    hit = (where == "between" and isinstance(e, ev.StageFinished) and e.index == k - 1) or \
          (where == "inside" and isinstance(e, ev.FramePreview) and e.index == k and e.frame == 2 and not e.dark)
    if hit:
        committed.wait(600)
        print("READY", flush=True)
        while True:
            time.sleep(1)
r.add_listener(hold)
r.run()
"""


@pytest.mark.parametrize("where", ["between", "inside"])
def test_sigkill_after_k_stages_leaves_k_readable_stages(tmp_path, where):
    k = 3
    out = tmp_path / "run"
    p = subprocess.Popen([sys.executable, "-c", CHILD, str(SMALL / "ptc_small.xml"), str(k), where, str(out)],
                         stdout=subprocess.PIPE, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        line = p.stdout.readline()
        assert line.strip() == b"READY"
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=600)
    rec = load_run(out)
    assert rec.meta["status"] == "running"  # never finished
    assert [s["index"] for s in rec.stages] == list(range(k))
    with h5py.File(out / "results.h5", "r") as f:
        assert sorted(f["stages"]) == [f"{i:04d}" for i in range(k)]
        assert f[f"stages/{k - 1:04d}/mean"][()].shape == (24, 32)
    assert len(list(csv.DictReader((out / "summary.csv").open()))) == k
    for i in range(k):
        with h5py.File(out / "frames" / f"{i:04d}.h5", "r") as f:
            assert f["frames"].shape[0] == 4


def test_pdf_output_option_writes_the_report(tmp_path):
    import dataclasses

    from ares.protocol import Output

    sc = load_scan(SMALL / "ptc_small.xml")
    sc = dataclasses.replace(sc, output=Output(raw_frames=False, hdf5=True, csv=False, pdf=True))
    out = Runner(sc, out_dir=tmp_path / "r", frames=3).run()
    assert out.status == "done"
    meta = json.loads((tmp_path / "r" / "run.json").read_text())
    assert "report_error" not in meta, meta.get("report_error")
    assert (tmp_path / "r" / "report.pdf").read_bytes()[:5] == b"%PDF-"
    assert not (tmp_path / "r" / "summary.csv").exists()  # csv="false"


def test_bench_failure_is_recorded_in_the_run_directory(tmp_path):
    from ares.errors import DeviceGone

    sc = load_scan(ROOT / "scans" / "photon_transfer.xml", system_path=ROOT / "protocols" / "black_widow.xml")
    with pytest.raises(DeviceGone):  # no I2C bus / USB grabber on the test machine
        Runner(sc, out_dir=tmp_path / "bw").run()
    meta = json.loads((tmp_path / "bw" / "run.json").read_text())
    assert meta["status"] == "failed" and meta["stages_completed"] == 0 and meta["system_name"] == "black_widow"
