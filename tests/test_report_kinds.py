"""Every shipped scan, run with few frames on the simulator, leaves a report whose pages
match what it measured, and states every figure the same on every surface (terminal,
JSON, CSV, HDF5, PDF, the window's models: ``one_truth.check_surfaces``) (issue: reports for every scan kind): a dark-current scan has its
dark-current pages, a 2-D sweep its maps with axis units, an ADC scan its INL/DNL page, the
MTF, photon-counting, spectral-QE, Fe-55, RTN and per-pixel dark-vs-temperature scans their
pages, and
no scan gets photon-transfer pages it did not measure; no page is blank. (emva_4.xml is
checked in test_emva4_scan.py; emva_reference.xml needs ../shared/data.)"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")  # the window's tabs are read too (one_truth)

from ares.cli import main
from one_truth import check_defect_classes, check_masked_names, check_names, check_surfaces, check_window_components
from pdfrender import ink, render
from pdftext import page_texts

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / "EMVA1288_Data.txt"

# scan -> (page texts that must appear, texts that must not)
EXPECT = {
    "photon_transfer": (["Photon transfer (analog gain x1)", "SNR and linearity", "Noise components",
                         "Signal and noise maps", "Defects", "Defect map", "Stages"], []),
    "ptc_exposure": (["Photon transfer (analog gain x1)", "SNR and linearity", "Noise components"], ["Defect map"]),
    "dark_current": (["Dark signal vs exposure", "Defects", "Defect map", "exposure (s)"], []),
    "temperature": (["Dark current vs temperature", "2-D sweep", "temperature (C)", "exposure (s)"],
                    ["Photon transfer", "SNR and linearity"]),
    "gain": (["Gain split: conversion gain and noise vs analog gain", "Photon transfer (analog gain x1)"], []),
    "bias_sweep_2d": (["2-D sweep", "tx_low (V)", "sf_bias (V)", "image lag"], ["Photon transfer", "SNR and linearity"]),
    "adc_linearity": (["ADC linearity: INL and DNL", "integral non-linearity"], []),
    "lag": (["Frame means per stage and image lag", "Image lag", "lag vs frame", "lag vs tx_low",
             "tx_low (V)"], ["Photon transfer", "SNR and linearity"]),
    "emva_reference": (["Scan-level analysis: emva1288", "EMVA 1288 reference data set"], []),
    "mtf": (["Slanted-edge MTF: stage edge", "MTF figures", "option 16 px", "images a slanted edge"],
            ["Photon transfer (analog gain", "SNR and linearity"]),
    "photon_counting": (["Photon-counting histogram: stage low_light", "Photon counting beside photon transfer",
                         "SE ratio"], ["Photon transfer (analog gain", "SNR and linearity"]),
    "spectral_qe": (["Spectral quantum efficiency", "QE per wavelength", "outside the photodiode's calibration table",
                     "Photon transfer (analog gain x1)"], ["Scan-level analysis: spectral_qe"]),
    "fe55": (["Fe-55 X-ray gain: stage xray", "K-alpha peak (3x3 signal)", "inverse system gain 1/K (Fe-55 K-alpha)"],
             ["Photon transfer (analog gain", "SNR and linearity"]),
    "rtn": (["Random telegraph noise", "pixel temporal noise sqrt(Pt), all pixels"],
            ["Photon transfer (analog gain", "SNR and linearity"]),
    "dark_temperature": (["Dark current against temperature, per pixel", "Dark current vs temperature",
                          "temperature (C)"], ["Photon transfer (analog gain", "SNR and linearity"]),
    "genicam_quick": (["Noise components", "Stages"], ["Photon transfer (analog gain", "SNR and linearity"]),
    "photon_transfer_precision": (["Photon transfer (analog gain x1)", "SNR and linearity", "Defect map"], []),
}
# frames per stage for the check (3 unless said): RTN needs its long dark series
FRAMES = {"rtn": None}


# the main job, the replayed reference CCD, the MTF and photon-counting kinds in the suite; every other shipped
# scan's report in make bench-quick (the same check, tests marked study)
IN_SUITE = {"photon_transfer", "emva_reference", "mtf", "photon_counting"}


@pytest.mark.parametrize("name", [n if n in IN_SUITE else pytest.param(n, marks=pytest.mark.study)
                                  for n in sorted(EXPECT)])
def test_report_pages_match_what_the_scan_measured(name, tmp_path, capsys, shared_run, qtbot):
    if name == "emva_reference" and not DATA.is_file():
        pytest.skip("the EMVA reference data set is not in ../shared/data/")
    if name == "emva_reference":  # the run test_replay_bench.py checks too (~60 s): made once
        out, rc, terminal = shared_run("emva_reference", ["run", str(ROOT / "scans" / "emva_reference.xml"),
                                                          "--seed", "2", "--quiet"])
    else:
        out = tmp_path / "run"
        frames = FRAMES.get(name, "3")
        args = ["run", str(ROOT / "scans" / f"{name}.xml"), "--out", str(out), "--seed", "2", "--quiet",
                *(["--frames", frames] if frames else [])]
        capsys.readouterr()
        rc = main(args)
        terminal = capsys.readouterr().out
    assert rc in (0, 4)  # 4: a limit failed with so few frames -- the report is still written
    pdf = out / "report.pdf"
    assert pdf.is_file(), f"{name}: no report.pdf"
    pages = page_texts(pdf)
    text = " ".join(pages)
    must, must_not = EXPECT[name]
    for t in must:
        assert t in text, f"{name}: no '{t}' in its report"
    for t in must_not:
        assert t not in text, f"{name}: '{t}' in a report of a scan that did not measure it"
    assert pages[0].startswith(f"ARES report: {name}")
    for png in render(pdf, tmp_path / "png", scale=0.25):
        assert ink(png) > 0.002, f"{png.name}: blank page"
    for csv in ("summary.csv", "key_figures.csv", "levels.csv"):
        assert (out / csv).is_file(), csv
    check_surfaces(name, out, terminal)
    check_defect_classes(name, out, terminal)
    check_names(name, out, terminal)  # issue 52: one name, one value; units in report.h5
    check_window_components(name, out, terminal, qtbot)
    if name == "photon_transfer":
        check_masked_names(out)
    if name == "emva_reference":
        check_headline_k(out)


def check_headline_k(out: Path) -> None:
    """The reference CCD's K (issues 34, 48): its brighter-fatter curvature is significant,
    so the report's headline is the Astier fit's zero-signal K, never a line over the bent
    range (issue 48); the datasheet's EMVA 1288 4.0 Linear Eq. 50 K (unweighted least
    squares with offset, 0-70 % of saturation) is shown beside it, and the sentence both
    show names the headline, why, the Eq. 50 K and why they differ. The Eq. 50 K is checked
    by the closed-form OLS slope of ptc.csv's fit levels."""
    import csv
    import json

    import numpy as np

    res = json.loads((out / "scan_results.json").read_text())["analyses"]
    head = res["ptc"]["gain_headline"]
    k, k50 = head["headline"], head["eq50"]
    assert head["estimator"] == "astier" and "curvature term is significant" in head["reason"]
    assert (k50["value"], k50["se"]) == (res["emva4"]["values"]["K"]["value"], res["emva4"]["values"]["K"]["se"])
    assert head["difference"]["value"] == pytest.approx(k["value"] - k50["value"])
    assert head["z"] > 2 and "the curve is not a line" in head["statement"]
    for text in ("the Astier 2019 fit", "Eq. 50 as written", "unweighted least squares with offset"):
        assert text in head["statement"], text
    with open(out / "ptc.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["status"] == "fit"]
    s = np.array([float(r["signal_dn"]) for r in rows])
    v = np.array([float(r["variance_dn2"]) for r in rows])
    assert np.polyfit(s, v, 1)[0] == pytest.approx(k50["value"], rel=1e-6)
    assert k["value"] > k50["value"]  # the zero-signal slope, above a line over the flattening curve
