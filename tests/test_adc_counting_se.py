"""INL/DNL with standard errors (issue 38: the ADC page gave bare extremes and the curves
were not exported). The code-density test's counting SE (the fallback for one histogram)
against a Monte Carlo of an ideal ADC fed i.i.d. uniform samples, and the curves in
adc_inl_dnl.csv / report.h5 with the extremes the JSON states (their SEs from the ramp's
sub-histograms: tests/test_adc_scatter_se.py)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from ares.analysis.ptc.adc import code_density
from ares.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_counting_se_matches_the_spread_of_an_ideal_adc():
    rng = np.random.default_rng(11)
    reps = [code_density(np.floor(rng.uniform(0, 256, 20000)).astype(int), 255) for _ in range(300)]
    for k in (40, 128, 200):
        dnl = np.array([r.dnl[k] for r in reps])
        inl = np.array([r.inl[k] for r in reps])
        # 300 replicates: the spread is known to ~4 %; the SE within 12 % of it
        assert np.mean([r.dnl_se()[k] for r in reps]) == pytest.approx(dnl.std(ddof=1), rel=0.12)
        assert np.mean([r.inl_se()[k] for r in reps]) == pytest.approx(inl.std(ddof=1), rel=0.12)
        assert abs(dnl.mean()) < 3 * dnl.std() / np.sqrt(300) + 0.01  # unbiased on an ideal ADC


def test_adc_scan_reports_extremes_with_se_and_exports_the_curves(tmp_path):
    out = tmp_path / "run"
    text = (ROOT / "scans" / "adc_linearity.xml").read_text()  # the shipped scan without the PDF (not read)
    old = 'href="../protocols/sim_sensor.xml"'
    assert old in text and "<output" not in text
    scan = tmp_path / "adc_linearity.xml"
    scan.write_text(text.replace(old, f'href="{ROOT / "protocols" / "sim_sensor.xml"}"').replace(
        "</scan>", '<output pdf="false"/>\n</scan>'))
    assert main(["run", str(scan), "--out", str(out), "--frames", "3",
                 "--seed", "2", "--quiet"]) in (0, 4)
    res = json.loads((out / "scan_results.json").read_text())["analyses"]["adc_linearity"]
    with open(out / "adc_inl_dnl.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    from ares.rundir.record import load_run
    from ares.results.adc import ramp_curves

    curves = ramp_curves(load_run(out))
    for ch, c in res["channels"].items():
        mine = [r for r in rows if r["channel"] == ch]
        assert mine, ch
        r = curves[ch]
        assert r.groups == 3 == c["sub_histograms"]  # --frames 3: the ramp's sub-histograms
        ext = r.extremes()
        for key in ("dnl_max", "inl_max", "dnl_min", "inl_min"):
            assert c[f"{key}_lsb"] == ext[key].to_dict()  # what the CSV's curves give, as the JSON states it
            assert "3 independent sub-histograms" in ext[key].note and "selection bias" in ext[key].note
        # the INL bow (0.5 LSB) is resolved; every extreme "ok" has its SE below its value
        assert c["inl_max_lsb"]["verdict"] == "ok" and 0 < c["inl_max_lsb"]["se"] < c["inl_max_lsb"]["value"]
        assert max(float(x["dnl_lsb"]) for x in mine) == pytest.approx(r.at_extremes()["dnl_max"][0])
        assert [float(x["dnl_se_lsb"]) for x in mine] == pytest.approx(r.dnl_se()[r.first:r.last])
        assert min(float(x["inl_lsb"]) for x in mine) == pytest.approx(r.at_extremes()["inl_min"][0])
    with h5py.File(out / "report.h5", "r") as h:
        assert h["adc_inl_dnl/inl_lsb"].attrs["unit"] == "LSB" and h["adc_inl_dnl/inl_lsb"].size == len(rows)
        assert json.loads(h["adc_inl_dnl"].attrs["se_note"]) == {ch: r.se_note() for ch, r in curves.items()}
