"""Bins and dynamic part-average-testing limits of a lot (``ares.batch.screens``), judged
against truth planted in a synthetic lot: items drawn from a normal, a few planted 12-sigma
outliers inside the static limits, a few outside them, errored ones; the lot file's
``<pat>`` and ``soft_bin=``; the bins and screens in the database; lot.pdf without a lot
file lists every quantity and draws its distribution."""

from __future__ import annotations

import numpy as np
import pytest

from ares.batch import db as rdb
from ares.batch.lot_report import judge
from ares.batch.screens import HARD_ERROR, HARD_LIMIT, HARD_PASS, HARD_SCREEN, pat_text, screen
from ares.protocol.lot import Pat, load_lot
from ares.protocol.scan import Limit


def _fig(v, se, unit):
    return {"label": "", "value": v, "se": se, "unit": unit, "verdict": "", "note": ""}


def planted(n=300, seed=5):
    """(results, truth): gain ~ N(0.30, 0.002) with outliers at +12 sigma (inside the static
    limit 0.25..0.40) at every 50th item, far outside the static limit at every 70th, errors
    at every 97th."""
    rng = np.random.default_rng(seed)
    out, truth = [], {}
    for i in range(n):
        r = {"item": f"/lot/w{i % 4}/die_{i:04d}", "status": "done", "kind": "run", "hash": f"{i:064x}"}
        g = float(rng.normal(0.30, 0.002))
        kind = "pass"
        if i % 97 == 3:
            r.update(status="error", error="broken")
            kind = "error"
        elif i % 70 == 7:
            g, kind = 0.5, "limit"
        elif i % 50 == 11:
            g, kind = 0.30 + 12 * 0.002, "outlier"
        if kind != "error":
            r["figures"] = {"gain_dn_per_e": _fig(g, 1e-4, "DN/e-"), "read_noise_e": _fig(3.0, 0.05, "e-")}
        out.append(r)
        truth[r["item"]] = kind
    return out, truth


def _judged():
    res, truth = planted()
    j = judge(res, [Limit("gain_dn_per_e", 0.25, 0.40)])
    screen(j, [Pat("gain_dn_per_e", 6.0)], (7,))
    return j, truth


def test_pat_limits_and_bins_match_the_planted_truth():
    j, truth = _judged()
    want = {"pass": (HARD_PASS, 1), "limit": (HARD_LIMIT, 7), "outlier": (HARD_SCREEN, 51), "error": (HARD_ERROR, 99)}
    for r in j.results:
        assert (r["hard_bin"], r["soft_bin"]) == want[truth[r["item"]]], r["item"]
        assert r["passed"] is (truth[r["item"]] == "pass")
    # the dynamic limits: median +- 6 IQR/1.349 of the items that passed the static limit (outliers included)
    base = [r["figures"]["gain_dn_per_e"]["value"] for r in j.results if truth[r["item"]] in ("pass", "outlier")]
    q25, q50, q75 = np.percentile(base, [25, 50, 75])
    s = next(x for x in j.screens if x["kind"] == "dynamic")
    assert s["centre"] == pytest.approx(q50) and s["sigma"] == pytest.approx((q75 - q25) / 1.349)
    assert s["low"] == pytest.approx(q50 - 6 * s["sigma"]) and s["sigma"] == pytest.approx(0.002, rel=0.15)
    n_out = sum(v == "outlier" for v in truth.values())
    assert s["n_failed"] == n_out and s["n_tested"] == len(base)
    assert j.yields[pat_text(Pat("gain_dn_per_e"))] == (len(base) - n_out, len(j.results))
    counts = {sb: b["count"] for sb, b in j.bins.items()}
    assert counts == {1: sum(v == "pass" for v in truth.values()), 7: sum(v == "limit" for v in truth.values()),
                      51: n_out, 99: sum(v == "error" for v in truth.values())}
    assert sum(counts.values()) == len(j.results)


def test_too_few_items_set_no_dynamic_limit_and_say_why():
    res, _ = planted(4)  # (item 3 errored: 3 measured)
    j = judge(res, [])
    screen(j, [Pat("gain_dn_per_e")])
    s = j.screens[0]
    assert s["low"] is None and "at least 4 are needed" in s["note"] and s["n_failed"] == 0


def test_lot_file_pat_and_bins_parse(tmp_path):
    f = tmp_path / "lot.xml"
    f.write_text('<lot name="L" version="1"><item path="a" sensor="S1" wafer="W2" x="1" y="2"/>'
                 '<limits><limit quantity="K" min="0.2" soft_bin="12"/><limit quantity="read_noise_e" max="3"/>'
                 '<pat quantity="read_noise_e" k="4.5"/><pat quantity="K" soft_bin="60"/></limits></lot>')
    lot = load_lot(f)
    assert lot.items[0].wafer == "W2" and lot.limit_bins == (12, None)
    assert lot.screens == (Pat("read_noise_e", 4.5, None), Pat("K", 6.0, 60))
    f.write_text('<lot name="L" version="1"><limits><pat quantity="K" k="-1"/></limits></lot>')
    with pytest.raises(Exception, match="k must be above 0"):
        load_lot(f)


def test_bins_and_screens_land_in_the_database(tmp_path):
    j, truth = _judged()
    with rdb.connect(str(tmp_path / "r.sqlite")) as db:
        lot_id = rdb.append_lot(db, "L", j)
        cols, rows = rdb.item_rows(db, lot_id)
        scr = rdb.screens(db, lot_id)
    hb, sb = cols.index("hard_bin"), cols.index("soft_bin")
    assert [(r[hb], r[sb]) for r in rows] == [(r["hard_bin"], r["soft_bin"]) for r in j.results]
    assert {s["kind"] for s in scr} == {"static", "dynamic"}
    dyn = next(s for s in scr if s["kind"] == "dynamic")
    assert dyn["n_failed"] == sum(v == "outlier" for v in truth.values()) and dyn["k"] == 6.0


def test_lot_pdf_without_a_lot_file_lists_every_quantity_with_its_distribution(tmp_path):
    from pdftext import pdf_text

    from ares.batch.lot_pdf import write_pdf

    rng = np.random.default_rng(1)
    res = [{"item": f"/l/i{i}", "status": "done", "kind": "run",
            "figures": {f"q{k:03d}": _fig(float(rng.normal(k, 1)), 0.1, "DN") for k in range(14)}} for i in range(30)]
    j = judge(res, [])
    screen(j)
    write_pdf(j, tmp_path / "lot.pdf", "nolot")
    text = pdf_text(tmp_path / "lot.pdf")
    assert all(f"q{k:03d}" in text for k in range(14))
    assert "Every quantity over the lot" in text and "Distributions (3/3)" in text
    assert "no limits set" in text and "3 of 14 quantities shown" in text
