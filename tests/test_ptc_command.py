"""``ares ptc TABLE``: photon transfer from a mean/variance table (issue 9).

The shipped example ``fixtures/ptc/sim_photon_transfer.csv`` is the ``ptc.csv`` of
``ares run scans/photon_transfer.xml`` (seed 1, the simulator's K = 0.28 DN/e-, full well
12000 e-); tests/test_scan_truth.py checks that a run's own table reproduces the run."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import pytest

from ares.cli import main

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "fixtures" / "ptc" / "sim_photon_transfer.csv"
K_TRUE, FW_TRUE = 0.28, 12000.0


def run_json(capsys, *args):
    assert main(["ptc", *map(str, args), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def rows():
    with open(TABLE, newline="") as f:
        return list(csv.DictReader(f))


def write(path: Path, rws, cols=None):
    cols = cols or list(rws[0])
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, cols, extrasaction="ignore")
        w.writeheader()
        w.writerows(rws)
    return path


def test_shipped_table_reproduces_the_simulator(capsys):
    d = run_json(capsys, TABLE)
    k, fw = d["gain_dn_per_e"], d["full_well_e"]
    assert abs(k["value"] - K_TRUE) < 3 * k["se"] and k["verdict"] == "ok"
    assert abs(fw["value"] - FW_TRUE) < 3 * fw["se"] + 0.02 * FW_TRUE
    assert d["saturation"]["reached"] and d["saturation"]["low_e"] < FW_TRUE < d["saturation"]["high_e"]
    assert d["read_noise_e"]["verdict"] == "ok" and d["dynamic_range_db"]["verdict"] == "ok"


def test_text_output_and_pdf(capsys, tmp_path):
    pdf = tmp_path / "ptc.pdf"
    assert main(["ptc", str(TABLE), "--pdf", str(pdf)]) == 0
    out = capsys.readouterr().out
    assert "system gain K" in out and "saturation between" in out and "excluded" in out
    assert pdf.read_bytes()[:5] == b"%PDF-" and not (tmp_path / "ptc.pdf.tmp").exists()


def test_unsorted_and_duplicated_rows(capsys, tmp_path):
    ref = run_json(capsys, TABLE)
    rws = rows()
    shuffled = rws[::-1] + rws[5:8]  # reversed order, three levels twice
    d = run_json(capsys, write(tmp_path / "t.csv", shuffled))
    assert d["gain_dn_per_e"]["value"] == pytest.approx(ref["gain_dn_per_e"]["value"], rel=2e-3)
    assert d["full_well_e"]["value"] == pytest.approx(ref["full_well_e"]["value"], rel=2e-3)
    assert not any(s["reason"].startswith("non-monotonic") for s in d["level_status"])


def test_nan_rows_are_excluded_with_a_reason(capsys, tmp_path):
    rws = rows()
    rws[3]["bright_variance_dn2"] = "nan"
    rws[4]["mean_dn"] = ""
    d = run_json(capsys, write(tmp_path / "t.csv", rws))
    st = d["level_status"]
    assert st[3]["status"] == st[4]["status"] == "excluded" and "non-finite" in st[3]["reason"]
    assert abs(d["gain_dn_per_e"]["value"] - K_TRUE) < 3 * d["gain_dn_per_e"]["se"]


def test_values_beyond_a_measurement_are_refused_and_infinities_excluded(capsys, tmp_path):
    """A cell beyond what a measurement holds (1e200 DN^2: a unit slip, a corrupt export) is
    one sentence naming its line and column, exit 2; an infinite cell is an empty one: its
    level is excluded with the reason and the rest still give the gain."""
    rws = rows()
    rws[3]["bright_variance_dn2"] = "1e200"
    assert main(["ptc", str(write(tmp_path / "t.csv", rws))]) == 2
    err = capsys.readouterr().err
    assert "t.csv:5: column 'var' = 1e+200 DN^2 is outside what a measurement holds" in err and err.count("\n") == 1
    rws[3]["bright_variance_dn2"] = "-inf"
    d = run_json(capsys, write(tmp_path / "t.csv", rws))
    assert d["level_status"][3]["status"] == "excluded" and "non-finite" in d["level_status"][3]["reason"]
    assert abs(d["gain_dn_per_e"]["value"] - K_TRUE) < 3 * d["gain_dn_per_e"]["se"]


@pytest.mark.parametrize("column, value, fragment", [
    ("n_frames", "1e200", "n_frames 1e+200 is not a frame count"),
    ("n_frames", "2.5", "n_frames 2.5 is not a frame count"),
    ("n_pixels", "0", "n_pixels 0 is not a pixel count"),
    ("exposure_s", "-0.01", "column 'exposure' = -0.01 s is outside"),
])
def test_counts_and_axes_out_of_range_name_the_line(capsys, tmp_path, column, value, fragment):
    rws = rows()
    assert column in rws[0]
    rws[2][column] = value
    assert main(["ptc", str(write(tmp_path / "t.csv", rws))]) == 2
    err = capsys.readouterr().err
    assert "t.csv:4:" in err and fragment in err and "Traceback" not in err


def test_whitespace_table_with_columns_and_no_dark(capsys, tmp_path):
    rws = rows()
    lines = [f"{float(r['signal_dn'])} {float(r['variance_dn2'])}" for r in rws]
    p = tmp_path / "t.txt"
    p.write_text("# dark-subtracted mean and variance\n" + "\n".join(lines) + "\n")
    d = run_json(capsys, p, "--columns", "mean,var", "--pixels", 307200, "--frames", 16)
    assert abs(d["gain_dn_per_e"]["value"] - K_TRUE) < 4 * d["gain_dn_per_e"]["se"]
    assert d["read_noise_e"]["verdict"] == "not available" and "dark" in d["read_noise_e"]["note"]
    assert any("dark" in n for n in d["notes"])


def test_without_pixel_counts_the_se_comes_from_the_scatter(capsys, tmp_path):
    cols = ["mean_dn", "bright_variance_dn2", "dark_mean_dn", "dark_variance_dn2"]
    d = run_json(capsys, write(tmp_path / "t.csv", rows(), cols))
    k = d["gain_dn_per_e"]
    assert k["se"] is not None and 0 < k["se"] < 0.01 and abs(k["value"] - K_TRUE) < 4 * k["se"]
    assert any("pixel counts" in n for n in d["notes"])


@pytest.mark.parametrize("content, args, fragment", [
    ("mean,var\n100,20\n", [], "one level is not a photon-transfer curve"),
    ("mean,var\n", [], "header but no data rows"),
    ("", [], "no rows"),
    ("signal,foo\n1,2\n3,4\n", [], "no column for mean, var"),
    ("1 2\n3 4\n", [], "no header row"),
    ("mean,var\n1,2\n3,abc\n", [], "t.csv:3: column 'var' is not a number"),
    ("mean,var\n1,2\n3\n", [], "t.csv:3: 1 column(s)"),
    ("1 2\n3 4\n", ["--columns", "mean,bogus"], "unknown field(s) bogus"),
])
def test_bad_tables_get_one_sentence(tmp_path, capsys, content, args, fragment):
    p = tmp_path / "t.csv"
    p.write_text(content)
    assert main(["ptc", str(p), *args]) == 2
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err and err.count("\n") == 1


def test_special_files_are_refused(tmp_path, capsys):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for path, fragment in ((fifo, "not a regular file"), (tmp_path, "is a directory"),
                           (tmp_path / "missing.csv", "not found"), (Path("/dev/zero"), "not a regular file")):
        assert main(["ptc", str(path)]) == 2
        assert fragment in capsys.readouterr().err


def test_fuzzed_tables_end_in_a_result_or_one_sentence(tmp_path, capsys):
    """Random damage to a good table (huge, tiny, negative, infinite, empty or fractional
    cells in any column): every run ends in exit 0 with verdicts or exit 2 with one
    sentence -- never an exception, never a numpy warning (turned into errors here)."""
    import random
    import warnings

    cols = ["mean", "var", "dark_mean", "dark_var", "n_pixels", "n_frames", "exposure", "photons", "signal_se"]
    base = [{"mean": 64 + 100.0 * k, "var": 4 + 30.0 * k, "dark_mean": 64, "dark_var": 4, "n_pixels": 10000,
             "n_frames": 2, "exposure": 0.001 * k, "photons": 1000 * k, "signal_se": 0.1} for k in range(1, 12)]
    bad = ["1e200", "-1e200", "1e308", "-0", "0", "1e-320", "inf", "-inf", "nan", "3.5e38", "-5", "1", "2.5", ""]
    rng = random.Random(7)
    for trial in range(60):
        rws = [dict(r) for r in base[:rng.randint(2, len(base))]]
        for _ in range(rng.randint(1, 4)):
            rws[rng.randrange(len(rws))][rng.choice(cols)] = rng.choice(bad)
        path = write(tmp_path / f"t{trial}.csv", rws, cols)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rc = main(["ptc", str(path), "--json"])
        err = capsys.readouterr().err
        assert rc in (0, 2), (trial, err)
        assert (rc == 0) == (err == "") and err.count("\n") <= 1, (trial, err)
