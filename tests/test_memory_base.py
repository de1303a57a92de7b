"""The memory estimate's base (the libraries a run imports) measured at install on this
machine (``ares.memory_base``, written by ``python -m ares.jit``), used only while the
packages are the ones it was measured with; otherwise the fitted constant, and the note
says so."""

from __future__ import annotations

import json
from pathlib import Path

from ares import memory_base
from ares.protocol import load_scan
from ares.scan import preflight

ROOT = Path(__file__).resolve().parents[1]


def test_the_base_is_measured_recorded_and_dropped_when_a_package_changes(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))  # the record lives beside numba's cache
    assert memory_base.recorded() is None
    got = memory_base.record()
    assert got is not None and 100 * 2**20 < got < 2**30  # numpy, scipy, numba, matplotlib...: some 200-300 MiB
    assert memory_base.record_path().is_file() and memory_base.recorded() == got
    assert preflight.base_bytes() == got + preflight.RUN_BYTES
    scan = load_scan(ROOT / "scans" / "mtf.xml")
    assert "assumed" not in preflight.check_run(scan, refuse_disk=False).memory_note()

    data = json.loads(memory_base.record_path().read_text())
    data["versions"]["numba"] = "0.0.1"  # an upgrade since the install: the record no longer holds
    memory_base.record_path().write_text(json.dumps(data))
    assert memory_base.recorded() is None
    assert preflight.base_bytes() == preflight.IMPORT_BYTES + preflight.RUN_BYTES
    monkeypatch.setattr("ares.analysis.kernels.jit.kernels_cached", lambda: True)  # (this cache folder holds no kernels)
    note = preflight.check_run(scan, refuse_disk=False).memory_note()
    assert "the libraries' share assumed, not measured on this machine: `python -m ares.jit` measures it" in note


def test_a_corrupt_record_is_no_record(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    memory_base.record_path().parent.mkdir(parents=True)
    for text in ("", "{", "[1, 2]", json.dumps({"bytes": "many", "versions": memory_base.versions()})):
        memory_base.record_path().write_text(text)
        assert memory_base.recorded() is None, text


def test_the_held_stages_are_those_the_runner_holds():
    """``preflight.held_stages`` against what the runner does (``ares.scan.mask_complete``):
    photon_transfer.xml completes the mask with its 9th flat of 25 (a run's StageUpdated events:
    the dark and ptc[0]-ptc[7] rewritten, ptc[8] committed with the complete mask), lag.xml's flats have no matched dark so all its stages after
    the first dark are held to the end, temperature.xml has no flat and holds nothing."""
    from ares.scan.stages import expand

    def held(name):
        return [st.name for st in preflight.held_stages(expand(load_scan(ROOT / "scans" / f"{name}.xml")))]

    assert held("photon_transfer") == [f"ptc[{k}]" for k in range(9)]
    assert held("lag") == ["bright_b", "after_b", "bright_c", "after_c"]
    assert held("temperature") == []
