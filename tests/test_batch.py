"""``ares batch`` on a 2-worker Dask LocalCluster: eight simulated runs give the same key
figures as ``ares report`` on each, a corrupt item is reported while the rest complete,
results are cached per item content, the lot file's limits give pass/fail and yields in the
CSV/HDF5/PDF lot report, and a 1080p stack split over the workers gives the bit-identical
decomposition of one process."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from ares.cli import main
from ares.errors import InputError

pytest.importorskip("distributed")

from test_report import PTC, SCAN, tiny_system  # noqa: E402

N_RUNS = 8


@pytest.fixture(scope="module")
def client():
    from ares.batch.cluster import make_client

    c = make_client(workers=2)
    yield c
    c.close()
    c.cluster.close()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("lot")
    system = tiny_system(base / "sim_tiny.xml")
    spec = dict(PTC, extra='<output pdf="false" csv="false"/>')
    xml = base / "ptc_tiny.xml"
    xml.write_text(SCAN.format(system=system.name, **spec))
    dirs = []
    for i in range(N_RUNS):
        d = base / f"s{i:02d}"
        assert main(["run", str(xml), "--out", str(d), "--seed", str(i), "-q"]) == 0
        dirs.append(d)
    bad = base / "bad"
    bad.mkdir()
    (bad / "run.json").write_text("{not json")
    return base, dirs, bad


def test_batch_equals_report_and_isolates_a_corrupt_item(client, runs, tmp_path):
    from ares.batch.cluster import run_items
    from ares.report import key_figures

    base, dirs, bad = runs
    seen = []
    res = run_items(client, [str(d) for d in dirs] + [str(bad)], str(tmp_path / "cache"),
                    progress=lambda k, n, r: seen.append((k, n)))
    assert seen[-1] == (N_RUNS + 1, N_RUNS + 1)
    assert res[-1]["status"] == "error" and "run.json" in res[-1]["error"]
    for d, r in zip(dirs, res):
        assert r["status"] == "done" and r["item"] == str(d)
        kf = key_figures(d)
        assert set(r["figures"]) == set(kf)
        for k, v in kf.items():
            assert r["figures"][k]["value"] == v["value"] and r["figures"][k]["se"] == v["se"], (d, k)
    # the figures differ between the sensors (eight seeds), so the comparison is not vacuous
    assert len({r["figures"]["gain_dn_per_e"]["value"] for r in res[:-1]}) == N_RUNS


def test_cache_recomputes_only_what_changed(client, runs, tmp_path):
    from ares.batch.cluster import run_items

    base, dirs, _ = runs
    cache = str(tmp_path / "cache")
    items = [str(d) for d in dirs[:4]]
    first = run_items(client, items, cache)
    assert not any(r["cached"] for r in first)
    again = run_items(client, items, cache)
    assert all(r["cached"] for r in again)
    assert [r["figures"] for r in again] == [r["figures"] for r in first]
    changed = tmp_path / "changed"
    import shutil

    shutil.copytree(dirs[0], changed)
    meta = json.loads((changed / "run.json").read_text())
    meta["note"] = "edited"  # a different content hash
    (changed / "run.json").write_text(json.dumps(meta))
    third = run_items(client, items + [str(changed)], cache)
    assert [r["cached"] for r in third] == [True, True, True, True, False]


def test_lot_file_limits_yield_and_report_files(client, runs, tmp_path, capsys):
    base, dirs, bad = runs
    lot = base / "lot.xml"
    items = "\n".join(f'  <item path="{d.name}" sensor="S{i}" x="{i % 3}" y="{i // 3}"/>' for i, d in enumerate(dirs))
    lot.write_text(f'''<?xml version="1.0" encoding="UTF-8"?>
<lot name="wafer_7" version="1">
{items}
  <item path="bad" sensor="BAD"/>
  <limits>
    <limit quantity="read_noise_e" max="100"/>
    <limit quantity="gain_dn_per_e" min="0.5"/>
  </limits>
</lot>''')
    out = tmp_path / "out"
    addr = client.scheduler.address
    rc = main(["batch", "--lot", str(lot), "--out", str(out), "--scheduler", addr, "-q"])
    assert rc == 1  # one item could not be analysed; the rest are in the table
    rows = list(csv.DictReader((out / "lot.csv").open()))
    assert len(rows) == N_RUNS + 1
    good = [r for r in rows if r["status"] == "done"]
    assert all(r["read_noise_e <= 100"] == "pass" and r["gain_dn_per_e >= 0.5"] == "FAIL" for r in good)
    assert all(r["verdict"] == "FAIL" for r in good) and rows[-1]["status"] == "error"
    # the errored item fails every limit and stays in the yield's denominator
    assert rows[-1]["verdict"] == "error" and rows[-1]["read_noise_e <= 100"] == "FAIL"
    assert rows[0]["serial"] == "S0" and rows[0]["lot"] == "wafer_7" and (rows[4]["x"], rows[4]["y"]) == ("1.0", "1.0")
    assert rows[0]["run_dir"] == str(dirs[0]) and len(rows[0]["content_hash"]) == 64 and rows[0]["started"]
    from ares import __version__

    assert rows[0]["ares_version"] == __version__
    import h5py

    with h5py.File(out / "lot.h5") as f:
        assert json.loads(f.attrs["yield"]) == {"read_noise_e <= 100": [N_RUNS, N_RUNS + 1],
                                                "gain_dn_per_e >= 0.5": [0, N_RUNS + 1]}
        assert f["items/gain_dn_per_e"].shape == (N_RUNS + 1,)
    from pdftext import pdf_text

    text = pdf_text(out / "lot.pdf")
    assert "Lot report: wafer_7" in text and "Yield per limit" in text and "Wafer maps: verdict and bin" in text
    assert "Appendix: every item (1/1)" in text and "Appendix: every error" in text
    # without the failing item and with a limit they meet: exit 0
    ok = base / "ok.xml"  # item paths are relative to the lot file
    ok.write_text(lot.read_text().replace('  <item path="bad" sensor="BAD"/>\n', "")
                  .replace('min="0.5"', 'min="0.1"'))
    # (into the same --out: its items come from the lot's cache, not analysed again)
    assert main(["batch", "--lot", str(ok), "--out", str(out), "--scheduler", addr, "-q"]) == 0
    assert "8 from the cache" in capsys.readouterr().out


def test_lot_file_errors_name_the_line(tmp_path):
    from ares.protocol.lot import load_lot

    p = tmp_path / "lot.xml"
    p.write_text('<lot name="x" version="1">\n  <item path="a" x="1"/>\n</lot>')
    with pytest.raises(InputError, match=r"lot.xml:2: .*needs both x= and y="):
        load_lot(p)
    p.write_text('<lot name="x" version="1">\n  <limits>\n    <limit quantity="K"/>\n  </limits>\n</lot>')
    with pytest.raises(InputError, match=r"lot.xml:3: limit on 'K' needs min= or max="):
        load_lot(p)
    assert main(["batch", str(tmp_path / "missing_run")]) == 2


def test_split_1080p_stack_is_bit_identical(client, tmp_path):
    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.analysis.noise.anova import decompose_dark
    from ares.batch.cluster import split_accumulate

    rng = np.random.default_rng(5)
    stack = (1000 + rng.normal(0, 5, (6, 1080, 1920)) + rng.normal(0, 2, (1, 1, 1920))).astype(np.uint16)
    spec = tmp_path / "stack.npy"
    np.save(spec, stack)
    one = StackAccumulator(stack.shape[1:])
    for f in stack:
        one.add(f)
    split = split_accumulate(client, str(spec), 3)
    assert split.n_frames == 6
    a, b = decompose_dark(one), decompose_dark(split)
    assert {k: (e.value, e.se) for k, e in a.items()} == {k: (e.value, e.se) for k, e in b.items()}


def test_stack_and_descriptor_items(client, tmp_path):
    """A frame stack gives what ``ares analyze`` gives; an EMVA descriptor what ``ares emva``
    (Release 4.0 Linear) gives."""
    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.analysis.noise.decompose import StackAnalysis
    from ares.batch.cluster import run_items

    rng = np.random.default_rng(9)
    stack = (200 + rng.normal(0, 3, (5, 40, 60)) + rng.normal(0, 1, (1, 40, 1))).astype(np.uint16)
    np.save(tmp_path / "dark.npy", stack)
    items = [str(tmp_path / "dark.npy")]
    desc = Path(__file__).resolve().parents[2] / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / \
        "EMVA1288_Data.txt"
    if desc.is_file():
        items.append(str(desc))
    res = run_items(client, items, None)
    acc = StackAccumulator(stack.shape[1:])
    for f in stack:
        acc.add(f)
    want = StackAnalysis(acc).components()
    assert res[0]["kind"] == "stack"
    for k, e in want.items():
        assert res[0]["figures"][k]["value"] == (e.value if e.available else None), k
    if len(items) > 1:
        from ares.results.descriptor import analyse_descriptor

        assert res[1]["kind"] == "emva"
        # EMVA 1288 4.0's K is the lot vocabulary's gain_dn_per_e (one name for every item kind)
        assert "K" not in res[1]["figures"] and res[1]["figures"]["gain_dn_per_e"]["symbol"] == "K"
        assert res[1]["figures"]["gain_dn_per_e"]["value"] == analyse_descriptor(desc).sheet.values["K"].value


def test_rerun_any_item_on_a_worker(client, runs, tmp_path):
    """``ares batch --rerun``: a worker repeats a run from its directory alone (as ``ares
    rerun``) and the new run reproduces every stage result and key figure (simulator)."""
    from ares.batch.cluster import run_items
    from ares.report import key_figures

    base, dirs, _ = runs
    res = run_items(client, [str(d) for d in dirs[:2]], None, rerun_into=str(tmp_path / "reruns"))
    for d, r in zip(dirs, res):
        assert r["status"] == "done" and r["rerun_of"] == str(d) and Path(r["item"]).parent == tmp_path / "reruns"
        same, n = map(int, r["reproduced"].split("/"))
        assert n > 0 and same == n, r.get("differ")
        assert r["figures"]["gain_dn_per_e"]["value"] == key_figures(d)["gain_dn_per_e"]["value"]
