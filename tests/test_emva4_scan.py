"""``scans/emva_4.xml``: the full Release 4.0 Linear measurement set recorded on the
simulated sensor through the real Runner ends with the 4.0 datasheet -- a PDF laid out as
Section 10.2 / Appendix G (summary sheet, then every mandatory graph of Table 1), a CSV and
the JSON with the standard's quantity names and units, the release and the measurement
date -- and its figures match the simulator's truth."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from ares.cli import main
from pdftext import page_texts

ROOT = Path(__file__).resolve().parents[1]


TERMINAL: dict[str, str] = {}  # what `ares run` printed, for the one-name check


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    import contextlib
    import io

    out = tmp_path_factory.mktemp("emva4") / "run"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["run", str(ROOT / "scans" / "emva_4.xml"), "--out", str(out), "--seed", "3", "--quiet"]) == 0
    TERMINAL["text"] = buf.getvalue()
    return out


@pytest.fixture(scope="module")
def report_pages(run_dir):
    """report.pdf's text per page, read once for the tests below."""
    return page_texts(run_dir / "report.pdf")


def test_one_name_one_value_on_every_surface(run_dir):
    """Issue 52 on emva_4.xml: the headline figures under one name and one value on the
    terminal, the window, key_figures.csv and the PDF; the full well said to be where the ADC
    clips; saturation capacity and turnoff said to be one point."""
    from one_truth import check_names

    check_names("emva_4", run_dir, TERMINAL["text"])
    text = TERMINAL["text"]
    assert "where the ADC clips" in text  # 9200 e- is the 12-bit ADC's top, not the 12 000 e- well
    ptc = json.loads((run_dir / "scan_results.json").read_text())["analyses"]["ptc"]
    if ptc["saturation_capacity_e"]["value"] == ptc["turnoff_e"]["value"]:
        assert "are one point" in text

def test_datasheet_pdf_follows_section_10_2(run_dir, report_pages):
    pages = page_texts(run_dir / "emva_datasheet.pdf")
    first = pages[0]
    for text in ("EMVA 1288", "Summary Sheet for Operation Point 1", "measurement date:", "Photon transfer",
                 "Signal-to-noise ratio", "Quantum efficiency", "Overall system gain", "Temporal dark noise",
                 "Absolute sensitivity threshold", "Saturation capacity", "Dynamic range",
                 "Spatial nonuniformities", "DSNU1288.col", "PRNU1288.pix", "Linearity error", "Dark current",
                 "Release 4.0 Linear", "Exposure control", "Gain, black level"):
        assert text in first, text
    body = " ".join(pages[1:])
    for graph in ("Section 6.6", "Linearity error", "Dark current (Section 7)", "Section 8.6", "Section 8.7",
                  "Section 8.8", "Accumulated log histogram", "Stability check (Fig. 6)", "Measurement, release and notes"):
        assert graph in body, graph
    general = page_texts(run_dir / "emva_datasheet_general.pdf")  # Release 4.0 General: a datasheet of its own
    assert "Summary Sheet (Release 4.0 General)" in general[0]
    assert all("Release 4.0 General ·" in p and "Release 4.0 Linear" not in p for p in general)
    assert "General 6.6 - 6.8" in " ".join(general)
    report = report_pages
    assert any("Summary Sheet for Operation Point 1" in p for p in report)  # also in the run's report


def test_every_key_figure_is_in_the_report_pdf(run_dir, report_pages):
    """The 88 key figures of this run do not fit the title page: the rest are on "Key figures
    (continued)" pages, each figure's label, value and whole note (wrapped, not cut)."""
    import re

    from ares.report import key_figure_pages, key_figures

    n = 1 + next(i for i, p in enumerate(report_pages[1:]) if not p.startswith("Key figures (continued)"))
    assert n >= 4 and "more key figure(s) on the next page(s)" in report_pages[0]
    text = " ".join(report_pages[:n])
    rows = key_figure_pages.rows_of(key_figures(run_dir))
    assert len(rows) == sum(1 for _ in open(run_dir / "key_figures.csv")) - 1
    for r in rows:
        for cell in r:
            assert re.sub(r"\s+", " ", cell) in text, cell


def test_exact_figures_state_their_verdict_on_every_surface(run_dir, report_pages):
    """µp.sat is the photons declared for the saturation step (the scan's light x exposure),
    not measured: SE exactly 0, and beside it on every surface "(exact: declared photons)",
    one wording (``exact_text``), no invented SE. Every figure of the run with SE 0 says why."""
    import h5py

    from ares.analysis.stats.estimate import EXACT_PHOTONS, exact_text
    from ares.gui.runner_adapter import summarize
    from ares.report import key_figures
    from ares.report.page_tables import analysis_label

    res = json.loads((run_dir / "scan_results.json").read_text())["analyses"]
    mu = res["emva4"]["values"]["mu_p_sat"]
    with open(run_dir / "summary.csv", newline="") as f:  # truth: the photons the scan declared per stage
        declared = {float(r["light_photons_per_pixel_per_s"]) * float(r["exposure_s"]) for r in csv.DictReader(f)
                    if r["light_photons_per_pixel_per_s"] and r["exposure_s"]}
    assert any(math.isclose(mu["value"], p, rel_tol=1e-9) for p in declared)
    assert mu["se"] == 0 and mu["verdict"] == "ok" and mu["exact"] == EXACT_PHOTONS
    zero = []

    def walk(x, path):
        if isinstance(x, dict) and "value" in x and "unit" in x:
            if x.get("se") == 0:
                zero.append((path, x))
        elif isinstance(x, dict):
            for k, v in x.items():
                walk(v, f"{path}.{k}" if path else k)

    walk(res, "")
    assert {p for p, _ in zero} >= {"emva4.values.mu_p_sat", "emva4.general.values.mu_p_sat"}
    word = f"({exact_text(EXACT_PHOTONS)})"
    gui = summarize(res)["results"]
    kf = key_figures(run_dir)
    with open(run_dir / "key_figures.csv", newline="") as f:
        kcsv = {r["name"]: r for r in csv.DictReader(f)}
    with open(run_dir / "emva_datasheet.csv", newline="") as f:
        dcsv = {(r["release"], r["quantity"]): r for r in csv.DictReader(f)}
    with h5py.File(run_dir / "report.h5") as f:
        h5 = {n.decode(): t.decode() for n, t in zip(f["key_figures/name"][:], f["key_figures/note"][:])}
    for path, d in zero:  # every SE of exactly 0: its reason, on the terminal, the window, CSV, HDF5, PDF
        assert d.get("exact"), path
        text = f"{d['value']:.7g} {d['unit']} ({exact_text(d['exact'])})"
        assert text in TERMINAL["text"], (path, text)
        a, rest = path.split(".", 1)  # the window names an EMVA figure by its symbol, as the key figures
        assert gui.get(analysis_label(a, rest) if a == "emva4" else f"{a}: {rest}") == text, path
        assert kf[path]["exact"] == d["exact"] and kcsv[path]["note"].startswith(exact_text(d["exact"])), path
        assert h5[path].startswith(exact_text(d["exact"])), path
    assert dcsv[("EMVA 1288 Release 4.0 Linear", "mu_p_sat")]["definition"].startswith(exact_text(EXACT_PHOTONS))
    report = " ".join(report_pages)
    assert report.count(word) >= 3  # the key-figure rows (Linear, General) and the General summary sheet
    assert f"{mu['value']:.7g} photons {word}" in report


def test_values_match_truth_and_carry_their_verdicts(run_dir):
    res = json.loads((run_dir / "scan_results.json").read_text())["analyses"]["emva4"]
    assert res["release"] == "EMVA 1288 Release 4.0 Linear"
    assert res["meta"]["date"]  # the measurement date is stated
    v = res["values"]
    G = 70 * 1.5 / 250  # DN/e-: conversion gain x analog gain / ADC LSB of sim_sensor.xml
    assert abs(v["K"]["value"] - G) < 4 * v["K"]["se"]
    assert abs(v["QE"]["value"] - 60.0) < 4 * v["QE"]["se"]
    assert "within the 0.1 - 0.2 %" in res["saturation"]  # the fine steps hit the Section 6.6 window
    assert res["linear_model_holds"] is True
    for k in ("mu_e_sat", "DR", "SNR_max", "LE", "DSNU1288_col", "PRNU1288_pix", "mu_I_mean", "mu_I_var"):
        assert v[k]["verdict"] == "ok" and v[k]["se"] is not None and v[k]["se"] > 0, k
    assert math.isclose(v["PRNU1288_pix"]["value"], 1.0, rel_tol=0.03)  # prnu_pct 1 %
    gen = res["general"]["values"]
    # every step has SNR_p > 1: General gives mu_p.min only as "below the lowest step" (Section 6.8 has no
    # step at SNR_p = 1 to regress), consistent with the Linear Eq. 26 value
    assert gen["mu_p_min"]["verdict"] == "upper limit" and gen["mu_p_min"]["value"] > v["mu_p_min"]["value"]
    assert all(k in gen for k in ("QE", "K", "K_inv", "SNR_max_inv", "DSNU1288_row", "PRNU1288_pix", "LE",
                                  "mu_I_var"))
    assert gen["K"]["verdict"] == "not available" and "cannot be measured" in gen["K"]["note"]


def test_csv_has_the_standard_names_and_units(run_dir):
    rows = list(csv.DictReader((run_dir / "emva_datasheet.csv").open()))
    by = {r["quantity"]: r for r in rows if r["release"].endswith("4.0 Linear")}
    for k, unit in (("QE", "%"), ("K", "DN/e-"), ("K_inv", "e-/DN"), ("sigma_d", "e-"), ("mu_e_sat", "e-"),
                    ("DR_db", "dB"), ("DSNU1288_row", "e-"), ("PRNU1288_col", "%"), ("LE", "%"),
                    ("mu_I_mean", "e-/s"), ("mu_e_min_area", "e-/µm²")):
        assert by[k]["unit"] == unit, k
        assert by[k]["value"] and by[k]["verdict"] == "ok", k
    assert by["sigma_d"]["symbol"] == "σd"
    assert any(r["release"].endswith("4.0 General") for r in rows)


def test_general_figures_have_one_name_on_every_surface(run_dir, report_pages):
    """Every figure of the General Table 2 under its symbol (µp.sat.area, SNRp.max), never its
    key (mu_p_sat_area): on the terminal, key_figures.csv, the window, emva_datasheet.csv, the
    report and both datasheets."""
    from ares.analysis.emva.general_table import GENERAL_TABLE2
    from ares.gui.runner_adapter import summarize

    res = json.loads((run_dir / "scan_results.json").read_text())["analyses"]
    gen = res["emva4"]["general"]["values"]
    sym = {k: s for k, s, _ in GENERAL_TABLE2 if k in gen}
    assert len(sym) == len(GENERAL_TABLE2)
    with open(run_dir / "key_figures.csv", newline="") as f:
        kcsv = {r["name"]: r["label"] for r in csv.DictReader(f)}
    with open(run_dir / "emva_datasheet.csv", newline="") as f:
        dcsv = {r["quantity"]: r["symbol"] for r in csv.DictReader(f) if r["release"].endswith("General")}
    gui = summarize(res)["results"]
    term = TERMINAL["text"].split("4.0 General):", 1)[1]
    for k, s in sym.items():
        if f"emva4.general.values.{k}" in kcsv:
            assert kcsv[f"emva4.general.values.{k}"] == f"EMVA 1288 4.0 General {s}", k
        assert dcsv[k] == s and f"EMVA 1288 4.0 General {s}" in gui, k
        assert f"\n      {s} " in term, k
    # keys that are not their own symbol (SNR_max and sigma_d are also written in definitions,
    # "20 log10 SNR_max", and in the photon-transfer label "read noise sigma_d")
    raw = [k for k in sym if "_" in k and not k.endswith("_db") and k not in ("SNR_max", "sigma_d")]
    for name, pages in (("report", report_pages), ("datasheet", page_texts(run_dir / "emva_datasheet.pdf")),
                        ("general", page_texts(run_dir / "emva_datasheet_general.pdf"))):
        text = " ".join(pages)
        assert not [k for k in raw if k in text], (name, [k for k in raw if k in text])


def test_k_statement_once_on_page_one_beside_k(run_dir, report_pages):
    """The sentence naming the headline K beside Eq. 50's is on the title page once: as the K
    key figure's note, beside its value (not again in the header block above the table)."""
    from one_truth import _squash

    from ares.report import key_figures

    stmt = json.loads((run_dir / "scan_results.json").read_text())["analyses"]["ptc"]["gain_headline"]["statement"]
    assert key_figures(run_dir)["gain_dn_per_e"]["note"] == stmt
    assert _squash(report_pages[0]).count(_squash(stmt)) == 1
