"""``ares.report`` / ``ares report``: CSV tables equal the run directory's numbers, the PDF
has its pages and key figures as text, partial runs say so, bad directories are one
sentence (exit 2). Runs are tiny real runs of the simulator (fixtures/xml/small)."""

from __future__ import annotations

import csv
import json
import math
import re
import shutil
from pathlib import Path

import pytest

from pdftext import page_count, pdf_text

from ares.cli import main
from ares.errors import InputError
from ares.report import key_figures, read_run, write_reports
from ares.report import pdf as report_pdf
from ares.report import page_tables, pdf_parts
from ares.report import tables

ROOT = Path(__file__).resolve().parents[1]


def tiny_system(path: Path) -> Path:
    """protocols/sim_sensor.xml (whatever its size) on a 24x32 array (fast), written to ``path``."""
    text = (ROOT / "protocols" / "sim_sensor.xml").read_text()
    text = re.sub(r'<array rows="\d+" cols="\d+"', '<array rows="24" cols="32"', text)
    text = re.sub(r'<param name="rows" type="int" value="\d+"/>', '<param name="rows" type="int" value="24"/>', text)
    text = re.sub(r'<param name="cols" type="int" value="\d+"/>', '<param name="cols" type="int" value="32"/>', text)
    text = text.replace('<system name="sim_sensor"', '<system name="sim_tiny"')
    assert '<array rows="24" cols="32"' in text
    path.write_text(text)
    return path


SCAN = """<?xml version="1.0" encoding="UTF-8"?>
<scan name="{name}" version="1">
  <system href="{system}"/>
  <settings>{settings}</settings>
  <frames>{frames}</frames>
  <stages>{stages}</stages>
  <analyses>{analyses}</analyses>
  {extra}
</scan>
"""
PTC = dict(name="ptc_tiny", frames=4,
           settings='<set quantity="exposure" value="0.01"/><set quantity="analog_gain" value="1"/>',
           stages='<stage name="dark" scene="dark"/><sweep name="ptc" scene="flat" dark="matched">'
                  '<axis quantity="light"><log start="10000" stop="10000000" points="9"/></axis></sweep>',
           analyses='<analysis name="decomposition"/><analysis name="ptc"/><analysis name="defects"/>',
           extra='<limits><limit quantity="read_noise_e" max="50"/></limits>')
DARK = dict(name="dark_t", frames=3, settings='<set quantity="analog_gain" value="1"/>',
            stages='<sweep name="dark" scene="dark"><axis quantity="temperature"><values>20 40 60</values></axis>'
                   '<axis quantity="exposure"><values>0.01 0.1 0.2 0.3 0.45 0.6</values></axis></sweep>',
            analyses='<analysis name="decomposition"/><analysis name="dark_current"/>'
                     '<analysis name="temperature"/>', extra="")
LAG = dict(name="lag_t", frames=4,
           settings='<set quantity="exposure" value="0.01"/><set quantity="analog_gain" value="1"/>',
           stages='<stage name="bright_a" scene="flat"><set quantity="light" value="1000000"/></stage>'
                  '<stage name="after_a" scene="dark"/>'
                  '<stage name="bright_b" scene="flat"><set field="tx_low" value="-0.8"/>'
                  '<set quantity="light" value="1000000"/></stage>'
                  '<stage name="after_b" scene="dark"><set field="tx_low" value="-0.8"/></stage>',
           analyses='<analysis name="lag"/>', extra="")


def _run(args) -> None:
    rc = main(["run", *args, "-q"])
    assert rc in (0, 3, 4), rc


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("runs")
    system = tiny_system(base / "sim_tiny.xml")
    xml = {}
    for spec in (PTC, DARK, LAG):
        xml[spec["name"]] = base / f"{spec['name']}.xml"
        xml[spec["name"]].write_text(SCAN.format(system=system.name, **spec))
    _run([str(xml["ptc_tiny"]), "--out", str(base / "ptc")])
    _run([str(xml["ptc_tiny"]), "--out", str(base / "partial"), "--sim-fault", "disconnect_after_frames=30"])
    _run([str(xml["dark_t"]), "--out", str(base / "dark")])
    _run([str(xml["lag_t"]), "--out", str(base / "lag")])
    return base


@pytest.fixture(scope="module")
def ptc_pdf(runs, tmp_path_factory):
    """The PTC run's PDF, rendered once: (path, page titles)."""
    path = tmp_path_factory.mktemp("pdf") / "r.pdf"
    return path, pdf_parts.write_pdf(read_run(runs / "ptc"), path)


def _csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _f(s: str) -> float:
    return math.nan if s == "" else float(s)


def _same(a: float, b) -> bool:
    b = math.nan if b is None else float(b)
    return (math.isnan(a) and math.isnan(b)) or a == b


def _pdf_text(path: Path) -> str:
    return pdf_text(path)


def _pages(path: Path) -> int:
    return page_count(path)


# ------------------------------------------------------------------ CSV

def test_csv_tables_equal_run_directory(runs, tmp_path):
    files = write_reports(runs / "ptc", ("csv",), csv_dir=tmp_path)
    assert [p.name for p in files] == ["summary.csv", "ptc.csv", "components.csv", "levels.csv", "key_figures.csv"]
    assert (tmp_path / "summary.csv").read_bytes() == (runs / "ptc" / "summary.csv").read_bytes()
    stages = {json.loads(p.read_text())["name"]: json.loads(p.read_text())
              for p in (runs / "ptc" / "stages").glob("*.json")}
    sr = json.loads((runs / "ptc" / "scan_results.json").read_text())["analyses"]
    status = {r["stage"]: r for r in sr["ptc"]["level_status"]}

    ptc = _csv(tmp_path / "ptc.csv")
    assert [r["stage"] for r in ptc] == [r["stage"] for r in sr["ptc"]["level_status"]]
    # the PTC's level statistics: over the good pixels of the run's defect mask
    lv, dk = tables.ptc_level_keys([stages[r["stage"]] for r in ptc])
    assert lv == "level_masked"
    for r in ptc:
        st = stages[r["stage"]]
        full = st["views"]["full"]
        assert float(r["mean_dn"]) == full[lv]["mean_dn"]
        assert float(r["signal_dn"]) == full[lv]["mean_dn"] - full[dk]["mean_dn"]
        assert float(r["variance_dn2"]) == full[lv]["var_dn2"] - full[dk]["var_dn2"]
        assert float(r["variance_se_dn2"]) > 0
        assert float(r["exposure_s"]) == st["settings"]["exposure"] and float(r["light_photons_per_pixel_per_s"]) == st["settings"]["light"]
        assert float(r["photons_per_pixel"]) == pytest.approx(st["settings"]["light"] * st["settings"]["exposure"])
        assert (r["status"], r["reason"]) == (status[r["stage"]]["status"], status[r["stage"]]["reason"])

    comp = _csv(tmp_path / "components.csv")
    n = 0
    for st in stages.values():
        for view, v in st["views"].items():
            for part in ("components", "components_masked", "dark_components", "flat_anova"):
                for c, e in (v.get(part) or {}).items():
                    row = next(r for r in comp if r["stage"] == st["name"] and r["view"] == view
                               and r["part"] == part and r["component"] == c)
                    assert _same(_f(row["value"]), e["value"]) and _same(_f(row["se"]), e["se"])
                    assert row["unit"] == e["unit"]
                    n += 1
    assert n == len(comp)
    flat = next(r for r in comp if r["scene"] == "flat" and r["view"] == "full" and r["part"] == "components")
    thirteen = {r["component"] for r in comp if r["stage"] == flat["stage"] and r["view"] == "full"
                and r["part"] == "components"}
    assert set(tables.COMPONENTS) <= thirteen

    levels = _csv(tmp_path / "levels.csv")
    assert len(levels) == sum(len(st["views"]) for st in stages.values())
    for r in levels:
        v = stages[r["stage"]]["views"][r["view"]]
        for k in ("mean_dn", "var_dn2", "spatial_var_dn2", "frac_at_max"):
            assert _same(_f(r[k]), v["level"].get(k)), k
            assert _same(_f(r["dark_" + k]), (v.get("dark_level") or {}).get(k)), k

    kf = {r["name"]: r for r in _csv(tmp_path / "key_figures.csv")}
    for key in ("gain_dn_per_e", "gain_e_per_dn", "conversion_gain_uv_per_e", "read_noise_e", "read_noise_dn",
                "dynamic_range_db"):
        assert _same(_f(kf[key]["value"]), sr["ptc"][key]["value"]), key
        assert _same(_f(kf[key]["se"]), sr["ptc"][key]["se"]), key
        assert kf[key]["unit"] == sr["ptc"][key]["unit"]
    for d, e in sr["ptc"]["full_well_definitions"].items():
        row = kf[f"full_well_e.{d}"]
        assert _same(_f(row["value"]), e["value"]) and row["label"].startswith(("full well", "saturation capacity"))
        assert row["unit"] == "e-"
    assert {"snr_max", "qe", "linearity_error_pct"} <= set(kf)
    assert kf["gain_dn_per_e"]["unit"] == "DN/e-" and kf["conversion_gain_uv_per_e"]["unit"] == "uV/e-"


def test_hdf5_tables_equal_csv_and_link_the_stage_arrays(runs, tmp_path):
    import h5py
    import numpy as np

    files = write_reports(runs / "ptc", ("csv", "hdf5"), csv_dir=tmp_path, h5_path=runs / "ptc" / "report.h5")
    assert files[-1] == runs / "ptc" / "report.h5"
    with h5py.File(runs / "ptc" / "report.h5", "r") as f:
        for table in ("ptc", "components", "levels", "key_figures"):
            rows = _csv(tmp_path / f"{table}.csv")
            cols = json.loads(f[table].attrs["columns"])
            assert cols == list(rows[0].keys())
            for c in cols:
                ds = f[table][c]
                if ds.dtype.kind == "f":
                    assert np.array_equal(ds[()], np.array([_f(r[c]) for r in rows]), equal_nan=True), (table, c)
                else:
                    assert [x.decode() for x in ds[()]] == [r[c] for r in rows], (table, c)
        assert json.loads(f.attrs["run"])["scan_sha256"] == read_run(runs / "ptc").meta["scan_sha256"]
        assert f["stages/0001/mean"].shape == (24, 32)  # external link into results.h5


def test_missing_summary_csv_is_rebuilt_in_the_runners_layout(runs, tmp_path):
    d = tmp_path / "nocsv"
    shutil.copytree(runs / "ptc", d)
    (d / "summary.csv").unlink()
    files = write_reports(d, ("csv",))
    assert files[0] == d / "summary.csv"
    assert (d / "summary.csv").read_bytes() == (runs / "ptc" / "summary.csv").read_bytes()
    assert [p.name for p in write_reports(d, ("csv",))][0] == "ptc.csv"  # the run's own is left alone


def test_key_figures_api(runs):
    kf = key_figures(runs / "ptc")
    sr = json.loads((runs / "ptc" / "scan_results.json").read_text())["analyses"]["ptc"]
    assert kf["gain_dn_per_e"]["value"] == sr["gain_dn_per_e"]["value"]
    assert kf["read_noise_e"]["source"] == "scan_results.json: ptc"
    # the curves the report draws are recomputed from the stage results with the runner's inputs:
    # the same K as scan_results.json (else the PTC page carries a note saying they differ)
    g = tables.ptc_groups(read_run(runs / "ptc"))[0]
    assert g.result.gain_dn_per_e.value == pytest.approx(sr["gain_dn_per_e"]["value"], rel=1e-6)
    assert g.mismatch() == ""
    # the lot surfaces (lot PDF, certificate, lot_columns.csv) name a figure from its key alone (the
    # results database keeps no label): the same label the report gives it, but for what the run's
    # data add to it (a dark current's temperature, an analog gain)
    from ares.batch.vocabulary import quantity_label

    for name in ("ptc", "dark", "lag"):
        for k, f in key_figures(runs / name).items():
            assert f["label"].startswith(quantity_label(k)), (name, k, f["label"], quantity_label(k))
            assert f["label"] == quantity_label(k) or " at " in f["label"] or "(analog gain" in f["label"], (k, f["label"])


# ------------------------------------------------------------------ PDF

def test_pdf_pages_and_key_figures_as_text(runs, ptc_pdf):
    run = read_run(runs / "ptc")
    path, titles = ptc_pdf
    body = [t for t in titles if not t.startswith("key figures")]  # (continuation pages of the title's table)
    assert body[:3] == ["title", "ptc x1", "snr x1"] and "components" in titles and titles[-1] == "stages"
    assert any(t.startswith("maps") for t in titles)
    assert _pages(path) == len(titles)
    text = _pdf_text(path)
    kf = key_figures(runs / "ptc")
    for key in ("gain_dn_per_e", "read_noise_e", "conversion_gain_uv_per_e", "full_well_e.max_variance"):
        assert page_tables.fmt_value(kf[key]["value"], kf[key]["se"], kf[key]["unit"]) in text, key
    for words in ("Photon transfer", "SNR and linearity", "Noise components", "limits: all 1 passed",
                  run.meta["scan_sha256"], "read zone", "shot zone", "13 delta", "9 Cg"):
        assert words in text, words
    assert "Incomplete run" not in text and "Basler" not in text


def test_dark_temperature_run_pages(runs, tmp_path):
    titles = pdf_parts.write_pdf(read_run(runs / "dark"), tmp_path / "d.pdf")
    assert {"dark", "temperature", "sweep 2d"} <= set(titles) and not any(t.startswith("ptc") for t in titles)
    assert _pages(tmp_path / "d.pdf") == len(titles)
    sr = json.loads((runs / "dark" / "scan_results.json").read_text())["analyses"]
    kf = key_figures(runs / "dark")
    by_t = sr["dark_current"]["by_temperature"]
    for t in ("20C", "40C", "60C"):
        e = kf[f"dark_current.by_temperature.{t}.rate_dn_per_s"]
        assert e["value"] == by_t[t]["rate_dn_per_s"]["value"] and e["label"] == f"dark current ({t})"
    td = kf["temperature.doubling_temperature_c"]
    assert td["value"] == sr["temperature"]["doubling_temperature_c"]["value"] and td["unit"] == "C"
    text = _pdf_text(tmp_path / "d.pdf")
    assert "Dark current vs temperature" in text and "doubling temperature" in text
    assert page_tables.fmt_value(td["value"], td["se"], "C") in text


def test_report_computes_dark_current_without_the_analysis(runs, tmp_path):
    d = tmp_path / "noan"
    shutil.copytree(runs / "dark", d)
    (d / "scan_results.json").unlink()
    kf = key_figures(d)
    assert {"dark_current@20C_dn_per_s", "dark_current@60C_dn_per_s"} <= set(kf)
    sr = json.loads((runs / "dark" / "scan_results.json").read_text())["analyses"]["dark_current"]
    # the same line fit as the runner's analysis
    assert kf["dark_current@60C_dn_per_s"]["value"] == pytest.approx(
        sr["by_temperature"]["60C"]["rate_dn_per_s"]["value"], rel=1e-9)


def test_lag_and_defect_pages(runs, tmp_path, ptc_pdf):
    titles = pdf_parts.write_pdf(read_run(runs / "lag"), tmp_path / "l.pdf")
    assert "frame means" in titles
    sr = json.loads((runs / "lag" / "scan_results.json").read_text())["analyses"]["lag"]
    text = _pdf_text(tmp_path / "l.pdf")
    for bright, c in sr["cycles"].items():
        e = c["lag_pct"]
        assert page_tables.fmt_value(e["value"], e["se"], "%") in text
        assert key_figures(runs / "lag")[f"lag.cycles.{bright}.lag_pct"]["label"] == f"image lag ({bright})"
    sr = json.loads((runs / "ptc" / "scan_results.json").read_text())["analyses"]
    path, titles = ptc_pdf
    assert "defects" in titles
    kf = key_figures(runs / "ptc")
    assert kf["defects.total"]["value"] == sr["defects"]["counts"]["total"]
    text = _pdf_text(path)  # (read once for the checks below)
    assert "defect counts" in text
    # a count is exact by nature: an integer with its unit and the one wording, never a blank SE
    from ares.analysis.stats.estimate import EXACT_COUNT, exact_text

    total = sr["defects"]["counts"]["total"]
    assert kf["defects.total"]["se"] == 0 and kf["defects.total"]["exact"] == EXACT_COUNT
    assert f"{total} pixels ({exact_text(EXACT_COUNT)})" in " ".join(text.split())
    assert all(v.get("exact") == EXACT_COUNT for k, v in kf.items()
               if k.startswith("defects.") and v["value"] is not None or k == "decomposition.masked_pixels")
    # the defect map: every counted pixel of each class at its place, the criteria below
    d = sr["defects"]
    rows, cols = d["shape"]
    assert "defect map" in titles and rows * cols == read_run(runs / "ptc").stages[0]["views"]["full"]["level"]["n_pixels"]
    for cls, pts in d["locations"].items():
        assert len(pts) == d["counts"][cls]
        assert all(0 <= x < d["shape"][1] and 0 <= y < d["shape"][0] for x, y in pts)
    assert "Defect map" in text and "detection limits" in text


def test_emva_attribution(runs, tmp_path):
    d = tmp_path / "emva"
    shutil.copytree(runs / "ptc", d)
    meta = json.loads((d / "run.json").read_text())
    meta["scan_source"] = "../shared/data/EMVA1288_ReferenceSet_001_CCD_12Bit/EMVA1288_Descriptor.txt"
    (d / "run.json").write_text(json.dumps(meta))
    run = read_run(d)
    assert run.attribution == "EMVA 1288 reference data set, (C) 2011 Basler AG, CC BY-SA 3.0"
    # as the replay bench records it in run.json
    meta["scan_source"] = "x.xml"
    meta["bench"] = {"replay": True, "attribution": "EMVA 1288 reference data set, (C) 2011 Basler AG, CC BY-SA 3.0"}
    (d / "run.json").write_text(json.dumps(meta))
    assert read_run(d).attribution == run.attribution
    from matplotlib.backends.backend_pdf import PdfPages

    with PdfPages(d / "r.pdf") as pdf:  # the title page is enough (the footer of every page repeats it)
        pdf.savefig(report_pdf.title_page(run, tables.compute_key_figures(run)))
    assert "(C) 2011 Basler AG, CC BY-SA 3.0" in _pdf_text(d / "r.pdf")


def test_every_key_figure_is_in_the_pdf_whole(runs, tmp_path):
    """More key figures than the title page holds go on "Key figures (continued)" pages,
    none dropped; a long note wraps within its column (its verdict at its end is never
    cut) and no row is drawn into the footer."""
    from ares.report import key_figure_pages

    run = read_run(runs / "ptc")
    kf = dict(tables.compute_key_figures(run))
    verdict = "so this figure is NOT ok for the datasheet"
    for k in range(90):  # long, short and empty notes; the last words of each are its verdict
        note = ("sentence %d of a long note, " % k) * (k % 7) + (f"{verdict} (row {k})" if k % 3 else "")
        kf[f"extra{k}"] = {"label": f"extra figure {k}", "value": 1.0 + k, "se": 0.01, "unit": "DN", "note": note}
    pages = report_pdf.page_plan(run, kf=kf)
    kpages = [i for i, (t, _) in enumerate(pages) if t == "title" or t.startswith("key figures")]
    assert kpages == list(range(len(kpages))) and len(kpages) >= 3  # in order, right after the title page
    chunks = report_pdf.key_figure_chunks(run, kf)
    rows = key_figure_pages.rows_of(kf)
    assert [r for c in chunks for r in c] == rows  # every row once, in order
    from ares.report.plots import paginate  # a title page with no room left: every row on the next pages

    assert [len(c) for c in paginate(rows[:3], key_figure_pages.MAX_CHARS, 0.5, 60)] == [0, 3]
    drawn = []
    for i in kpages:  # drawn: each table ends above the footer
        texts = pages[i][1]().texts
        assert min(t.get_position()[1] for t in texts if t.get_text() in sum(chunks[i], [])) > 0.04
        drawn.append(" ".join(t.get_text() for t in texts))
    assert all(t.startswith("Key figures (continued)") for t in drawn[1:])
    text = " ".join(drawn)
    for r in rows:  # every cell whole: its wrapped lines are its words in order
        for cell in r:
            assert re.sub(r"\s+", " ", cell) in text, cell
    assert f"{len(rows) - len(chunks[0])} more key figure(s) on the next page(s)" in drawn[0]


# ------------------------------------------------------------------ partial / bad runs

def test_partial_run_is_reported_as_incomplete(runs, capsys):
    run = read_run(runs / "partial")
    assert not run.complete and 0 < len(run.stages) < 10
    assert main(["report", str(runs / "partial"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["complete"] is False and d["status"] == "failed" and "Incomplete run" in d["note"]
    assert f"{len(run.stages)} of 10 stage(s) completed" in d["note"]
    if run.scan_results is None or "gain_dn_per_e" not in run.analyses.get("ptc", {}):
        assert d["key_figures"]["gain_dn_per_e"]["source"].startswith("computed by the report")
    # a partial run that stopped before saturation: no full well, and the reason says why
    fw = d["key_figures"]["full_well_e"]
    assert fw["value"] is None and "saturation not reached" in fw["note"]
    assert {Path(p).name for p in d["files"]} == {"ptc.csv", "components.csv", "levels.csv", "key_figures.csv",
                                                  "report.h5", "report.pdf"}
    ptc = _csv(runs / "partial" / "ptc.csv")
    assert len(ptc) == sum(1 for s in run.stages if s["scene"] == "flat") and all(r["status"] for r in ptc)
    text = _pdf_text(runs / "partial" / "report.pdf")
    assert "Incomplete run (status 'failed')" in text and "disconnected" in text


def test_bad_directories_raise_one_sentence(tmp_path, runs, capsys):
    missing = tmp_path / "nope"
    with pytest.raises(InputError, match=f"{missing}: run directory does not exist"):
        write_reports(missing)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match=r"not an ARES run directory \(no run.json\)"):
        key_figures(empty)
    bad = tmp_path / "bad"
    shutil.copytree(runs / "ptc", bad)
    (bad / "stages" / "0003.json").write_text('{"index": 3, "na')
    with pytest.raises(InputError, match=r"0003\.json: unreadable"):
        read_run(bad)
    (bad / "stages" / "0003.json").write_text((runs / "ptc" / "stages" / "0003.json").read_text())
    (bad / "results.h5").write_bytes(b"not hdf5")
    with pytest.raises(InputError, match=r"results\.h5: unreadable HDF5"):
        write_reports(bad)
    (bad / "run.json").write_text("{not json")
    assert main(["report", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "run.json: unreadable" in err and str(bad) in err
    tampered = tmp_path / "tampered"
    shutil.copytree(runs / "ptc", tampered)
    xml = next((tampered / "xml").glob("ptc_tiny.xml"))
    xml.write_text(xml.read_text() + "<!-- edited -->\n")
    assert main(["report", str(tampered)]) == 2
    assert "SHA-256 differs" in capsys.readouterr().err
    assert main(["report", str(missing)]) == 2
    assert capsys.readouterr().err.strip() == f"ares report: {missing}: run directory does not exist"


@pytest.mark.parametrize("damage", ["deleted", "truncated", "not hdf5"])
def test_a_stage_file_missing_or_damaged_is_one_sentence_not_a_report_without_it(tmp_path, runs, capsys, damage):
    """results.h5 links each stage's arrays from stages/NNNN.h5; h5py reads a link it
    cannot follow as absent, so the report came out without that stage's maps, exit 0."""
    bad = tmp_path / "bad"
    shutil.copytree(runs / "ptc", bad)
    f = bad / "stages" / "0002.h5"
    if damage == "deleted":
        f.unlink()
    else:
        f.write_bytes(f.read_bytes()[:800] if damage == "truncated" else b"x" * 4000)
    assert main(["report", str(bad)]) == 2
    err = capsys.readouterr().err
    what = {"deleted": "incomplete: stage 2 ('ptc[1]'): its arrays (stages/0002.h5) are missing",
            "truncated": "corrupt: stage 2 ('ptc[1]'): stages/0002.h5 is truncated (800 of ",
            "not hdf5": "corrupt: stage 2 ('ptc[1]'): stages/0002.h5 is truncated (4000 of "}[damage]
    assert err.count("\n") == 1 and f"{bad}: {what}" in err and "ares rerun" in err


def test_cli_writes_only_what_is_asked(runs, tmp_path, capsys):
    run = tmp_path / "run"
    shutil.copytree(runs / "ptc", run)
    assert (run / "report.pdf").exists()  # every run writes its report by default
    (run / "report.pdf").unlink()
    assert main(["report", str(run), "--csv", str(tmp_path / "c")]) == 0
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["components.csv", "key_figures.csv", "levels.csv",
                                                                  "ptc.csv", "summary.csv"]
    assert not (run / "report.pdf").exists()
    cap = capsys.readouterr()
    assert len(cap.out.split()) == 5
    # what was left out is said (it was skipped silently), with the option that asks for it
    assert "not written: report.h5 (--hdf5 FILE), report.pdf (--pdf FILE)" in cap.err


def test_two_axis_sweep_maps_have_axis_units(tmp_path):
    """The 2-D sweep page: one map per figure over the two swept register fields, each axis
    labelled with the field's unit from the system XML kept in the run."""
    assert main(["run", str(ROOT / "fixtures" / "xml" / "small" / "bias_small.xml"), "--out", str(tmp_path / "b"),
                 "-q"]) == 4  # the fixture's limit fails on purpose
    titles = pdf_parts.write_pdf(read_run(tmp_path / "b"), tmp_path / "b.pdf")
    assert "sweep 2d" in titles and "ptc x1" not in titles  # a bias sweep is not a photon-transfer curve
    text = _pdf_text(tmp_path / "b.pdf")
    assert "2-D sweep 'bias': sf_bias x tx_low" in text
    assert "sf_bias (V)" in text and "tx_low (V)" in text


def test_defect_counts_are_exact_counts_or_a_lower_limit_with_units():
    """A defect count is exact (SE 0, "exact: counted", its unit); a class found incomplete
    (rate classes under a short exposure) is a lower limit "> n", and so is the total; the
    terminal prints each count with its unit."""
    import io

    from ares.analysis.stats.estimate import EXACT_COUNT
    from ares.commands.run_summary import _print_estimates
    from ares.report.tables import defect_count_figures

    a = {"counts": {"hot": 3, "dead": 2, "bad_columns": 1, "total": 5},
         "detection": {"hot": "incomplete: finds only dark rates >= 10 e-/s"}}
    kf = defect_count_figures(a)
    assert kf["defects.dead"]["exact"] == EXACT_COUNT and kf["defects.dead"]["se"] == 0
    assert kf["defects.bad_columns"]["unit"] == "columns"
    assert kf["defects.hot"]["verdict"] == "lower limit" and "exact" not in kf["defects.hot"]
    assert kf["defects.total"]["verdict"] == "lower limit"
    assert page_tables.fmt_value(3, None, "pixels", "lower limit") == "> 3 pixels"
    out = io.StringIO()
    _print_estimates({"counts": a["counts"]}, out, "  ")
    assert "hot 3 pixels, dead 2 pixels, bad_columns 1 columns, total 5 pixels" in out.getvalue()


def test_component_tables_show_every_value_whole(runs):
    """The components page: each component's value with its verdict ("< x", "not resolved from 0")
    whole in its cell (wrapped, never cut with "…"), in every table of the page."""
    from ares.report import pdf
    from ares.report.plots import new_page
    from ares.report.tables import component_text, mid_stage

    run = read_run(runs / "ptc")
    mid = mid_stage(run)
    full = mid["views"]["full"]
    for part in ("components", "flat_anova"):
        fig = new_page("t", "")
        pdf._component_table(fig, 0.92, mid, part, "t")
        joined = " ".join(t.get_text() for t in fig.texts)
        comps = (full.get("components_masked") if part == "components" and full.get("components_masked")
                 else full.get(part)) or {}
        assert comps, part
        for c, e in comps.items():
            assert component_text(c, e) in joined, (part, c, component_text(c, e))


def test_per_view_table_keeps_a_limits_verdict():
    """The per-view table shows a component known only as a limit as "< x" (the masked Ps of an
    incomplete defect mask), never the bound as a measured number; values without their SE."""
    from ares.report import pdf

    assert pdf._view_cell("Ps", {"value": 0.08286, "se": None, "unit": "DN^2", "verdict": "upper limit"}) == "< 0.083"
    assert pdf._view_cell("Ct", {"value": 0.0056, "se": 0.0099, "unit": "DN^2", "verdict": "ok"}) == "< 0.035"
    assert pdf._view_cell("Pt", {"value": 0.8265, "se": 0.0021, "unit": "DN^2", "verdict": "ok"}) == "0.8265"
    assert pdf._view_cell("Pt", {"value": None, "se": None, "unit": "DN^2", "verdict": "not available"}) == "n/a"
