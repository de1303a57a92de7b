"""One truth for the three stand-alone commands (issue 34, "done when": the consistency test
passes for `ares emva`/`ares analyze`/`ares ptc`): each command run twice, as text and as
--json, plus the files it writes (`ares emva --csv/--pdf`, `ares ptc --pdf`), and every
figure compared: the same value, SE digits, unit and verdict wherever it appears. Small
inputs: a 32 x 32 PNG EMVA set (tests/emva_pngset.py), the synthetic PTC table of
tests/test_turnoff.py, a 40 x 48 dark stack and a flat/dark pair of stacks."""

from __future__ import annotations

import csv
import json
import math
import re

import numpy as np
import pytest

from ares.analysis.stats.estimate import Estimate, component_text, format_dict
from ares.cli import main
from pdftext import page_texts


def _run(capsys, argv: list[str]) -> str:
    capsys.readouterr()
    assert main(argv) == 0, argv
    return capsys.readouterr().out


def _squash(text: str) -> str:
    return re.sub(r"\s+", " ", text)


# ------------------------------------------------------------------ ares emva

@pytest.fixture(scope="module")
def emva_set(tmp_path_factory):
    from emva_pngset import write_set

    return write_set(tmp_path_factory.mktemp("emva"), qe=0.6, dark_slope_dn_per_s=50.0)


def _emva_cell(text: str, key: str) -> str:
    """A quantity's row of `ares emva`'s table (its first line that starts with the key)."""
    return next(ln for ln in text.splitlines() if ln.split()[:1] == [key])


@pytest.mark.parametrize("release", ["4.0-linear", "4.0-general", "3.1", "3.0"])
def test_emva_text_json_csv_and_pdf_agree(capsys, tmp_path, emva_set, release):
    d = json.loads(_run(capsys, ["emva", str(emva_set), "--release", release, "--json"]))
    assert set(d) >= {"release", "values", "attribution"}, release  # one shape for every release
    values = d["values"]
    est = {k: Estimate.from_dict(v) for k, v in values.items() if isinstance(v, dict) and "verdict" in v}
    assert len(est) >= 10
    text = _run(capsys, ["emva", str(emva_set), "--release", release])
    cols = []
    for k, e in est.items():
        line = _emva_cell(text, k)
        want = e.text(with_unit=False) if e.available else "n/a"
        m = re.search(rf"\s{re.escape(want)}\s", line + " ")
        assert m, (release, k, line, want)
        cols.append(m.end())
    if release != "3.0":  # one value column: right-aligned at the same place on every row
        assert len(set(cols)) == 1, (release, sorted(set(cols)))
    out_csv, out_pdf = tmp_path / "s.csv", tmp_path / "s.pdf"
    _run(capsys, ["emva", str(emva_set), "--release", release, "--csv", str(out_csv)]
         + (["--pdf", str(out_pdf)] if release in ("4.0-linear", "3.1", "3.0") else []))
    with open(out_csv, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if (r["release"] == d["release"])]
    assert {r["quantity"] for r in rows} == set(est), release
    for r in rows:
        e = est[r["quantity"]]
        assert (r["unit"], r["verdict"]) == (e.unit, e.verdict), r
        for col, x in (("value", e.value), ("se", e.se)):
            if r[col] == "":
                assert not (e.available and (col == "value" or math.isfinite(x))), (r, col)
            else:
                assert float(r[col]) == x, (r, col)
    if release in ("4.0-linear", "3.1", "3.0"):
        pdf = _squash(" ".join(page_texts(out_pdf)))
        for k, e in est.items():
            if e.available:
                assert _squash(e.text(with_unit=False)) in pdf, (k, e.text())


# ------------------------------------------------------------------ ares ptc

def test_ptc_text_json_and_pdf_agree(capsys, tmp_path):
    from ares.labels import PTC_FIGURES
    from test_turnoff import curve, write

    s, v = curve("outlier")
    table = write(tmp_path / "t.csv", s, v)
    d = json.loads(_run(capsys, ["ptc", str(table), "--json"]))
    pdf = tmp_path / "p.pdf"
    text = _run(capsys, ["ptc", str(table), "--pdf", str(pdf)])
    w = max(len(label) for _, label in PTC_FIGURES)
    lines = {ln[2:2 + w].rstrip(): ln[3 + w:] for ln in text.splitlines() if ln.startswith("  ") and len(ln) > w + 3}
    for key, label in PTC_FIGURES:
        assert lines[label] == format_dict(d.get(key), with_reason=True), (key, lines[label])
    for label, key, field in (("gain model", "gain_model", "reason"), ("saturation", "saturation", "reason"),
                              ("linearity (Eq. 51)", "linearity_check_text", "note")):
        assert lines[label] == d[key][field], label
    # the PDF's plot legend: each K it draws is in the JSON, with the same digits and SE
    ptext = _squash(" ".join(page_texts(pdf)))
    legend = dict(re.findall(r"(headline \(WLS line\)|headline \(Astier\)|EMVA origin fit|Astier): K = "
                             r"([0-9.]+ ± [0-9.]+ DN/e-)", ptext))
    assert legend, ptext[:400]
    for name, key in (("headline (WLS line)", "gain_dn_per_e"), ("headline (Astier)", "gain_dn_per_e"),
                      ("EMVA origin fit", "gain_origin_dn_per_e"), ("Astier", "gain_astier_dn_per_e")):
        if name in legend:
            assert legend[name] == Estimate.from_dict(d[key]).text(), (name, legend[name])


# ------------------------------------------------------------------ ares analyze

def _stacks(tmp_path):
    rng = np.random.default_rng(7)
    shape = (40, 48)
    fpn = rng.normal(0, 3, shape)
    dark = np.round(200 + fpn + rng.normal(0, 2.0, (6,) + shape)).astype(np.uint16)
    gain = 1 + 0.01 * rng.standard_normal(shape)
    q = rng.poisson(np.broadcast_to(4000 * gain, (6,) + shape))
    flat = np.round(200 + fpn + 0.25 * q + rng.normal(0, 2.0, (6,) + shape)).astype(np.uint16)
    np.save(tmp_path / "dark.npy", dark)
    np.save(tmp_path / "flat.npy", flat)
    return str(tmp_path / "flat.npy"), str(tmp_path / "dark.npy")


@pytest.mark.parametrize("with_flat", [False, True])
def test_analyze_text_and_json_agree(capsys, tmp_path, with_flat):
    flat, dark = _stacks(tmp_path)
    argv = ["analyze", flat, "--dark", dark] if with_flat else ["analyze", dark]
    d = json.loads(_run(capsys, argv + ["--json"]))
    text = _run(capsys, argv)
    names = [k for k in d if not k.startswith("_")]
    seen = 0
    for line in text.splitlines():
        m = re.match(r"  (\S+)\s+", line)
        if not m or m.group(1) not in names:
            continue
        c = m.group(1)
        assert line[17:].startswith(component_text(c, d[c])), (c, line, component_text(c, d[c]))
        seen += 1
    assert seen == len(names)
    if with_flat:  # the flat stack's frame-global line and the JSON's
        fg = next(ln for ln in text.splitlines() if "flat stack frame-global" in ln)
        assert fg[17:].startswith(component_text("frame_global", d["_flat_stack"]["frame_global"])), fg
