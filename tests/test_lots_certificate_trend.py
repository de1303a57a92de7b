"""``ares lots certificate`` (a page per sensor with its identity, every figure with SE and
limit, bin and traceability) and ``ares lots trend`` (median and spread per lot, control
limits from the median moving range) against a database holding planted lots: a lot with a shifted median must be
the one flagged, and the limits are the moving-range formula computed here by hand."""

from __future__ import annotations

import csv

import numpy as np

from ares.batch import db as rdb
from ares.batch.lot_report import judge
from ares.batch.screens import screen
from ares.cli import main
from ares.protocol.lot import Pat
from ares.protocol.scan import Limit
from test_lots_screens import _judged


def _fig(v, se, unit):
    return {"label": "", "value": v, "se": se, "unit": unit, "verdict": "", "note": ""}


def _lot(centre: float, n: int = 40, seed: int = 0):
    rng = np.random.default_rng(seed)
    res = [{"item": f"/l/die{i}", "status": "done", "kind": "run", "hash": f"{i:064x}", "sensor": f"S{i}",
            "figures": {"gain_dn_per_e": _fig(float(rng.normal(centre, 0.002)), 1e-4, "DN/e-")}} for i in range(n)]
    j = judge(res, [Limit("gain_dn_per_e", 0.2, 0.4)])
    screen(j, [Pat("gain_dn_per_e")])
    return j


def test_trend_flags_the_shifted_lot_with_moving_range_limits(tmp_path, capsys):
    path = str(tmp_path / "r.sqlite")
    centres = [0.300, 0.3004, 0.2998, 0.3002, 0.330, 0.3001]
    with rdb.connect(path) as db:
        for k, c in enumerate(centres):
            rdb.append_lot(db, f"L{k}", _lot(c, n=20, seed=k))
    out = tmp_path / "gain.png"
    assert main(["lots", "trend", "K", "--db", path, "--out", str(out)]) == 0  # (K: the EMVA name of the gain)
    printed = capsys.readouterr().out
    rows = list(csv.DictReader((tmp_path / "gain.csv").open()))
    assert [r["lot"] for r in rows] == [f"L{k}" for k in range(6)] and out.stat().st_size > 10_000
    meds = np.array([float(r["median"]) for r in rows])
    sigma = np.median(np.abs(np.diff(meds))) / 0.954
    lo, hi = np.median(meds) - 3 * sigma, np.median(meds) + 3 * sigma
    assert [r["out_of_control"] for r in rows] == ["yes" if not lo <= m <= hi else "no" for m in meds]
    assert [r["lot"] for r in rows if r["out_of_control"] == "yes"] == ["L4"]
    assert f"control limits {lo:.5g} .. {hi:.5g}" in printed and "outside: L4" in printed
    assert main(["lots", "trend", "nothing_like_it", "--db", path]) == 2


def test_certificate_per_sensor_has_identity_figures_limits_bin_and_traceability(tmp_path, capsys):
    from pdftext import pdf_text

    j, truth = _judged()
    for i, r in enumerate(j.results):
        r.update(sensor=f"SN{i:04d}", wafer="W1", x=float(i % 10), y=float(i // 10), ares_version="9.9",
                 started="2026-01-02T03:04:05+00:00")
    path = str(tmp_path / "r.sqlite")
    with rdb.connect(path) as db:
        rdb.append_lot(db, "L1", j)
    outlier = next(r for r in j.results if truth[r["item"]] == "outlier")
    pdf = tmp_path / "one.pdf"
    assert main(["lots", "certificate", "L1", outlier["sensor"], "--db", path, "--out", str(pdf)]) == 0
    text = pdf_text(pdf)
    f = outlier["figures"]["gain_dn_per_e"]
    from ares.analysis.stats.estimate import format_value

    for want in (f"Certificate of performance: {outlier['sensor']}", "lot L1", "W1",
                 f"x {outlier['x']:g}, y {outlier['y']:g}", format_value(f["value"], f["se"]), "DN/e-",
                 ">= 0.25 and <= 0.4", "(k=6)", "hard 3 (outlier of a dynamic screen, fail), soft 51: outlier", outlier["hash"], "9.9",
                 "2026-01-02T03:04:05+00:00", "not available (the run directory is not at hand here)"):
        assert want in text, want
    with rdb.connect(path) as db:
        rdb.append_lot(db, "L2", _lot(0.3, n=5))
    all_pdf = tmp_path / "all.pdf"
    assert main(["lots", "certificate", "L2", "--db", path, "--out", str(all_pdf)]) == 0
    assert "5 certificate(s), 5 page(s)" in capsys.readouterr().out
    assert "Certificate of performance: S4" in pdf_text(all_pdf)
    assert main(["lots", "certificate", "L1", "nobody", "--db", path]) == 2


def test_certificate_holds_every_figure_whole_with_its_verdict(tmp_path):
    """A sensor with more figures than a page: none dropped or cut (wrapped, continued), a
    limit shown as one ("> 76.6", not "76.6 (SE not available)"), an exact value (SE 0) with
    its verdict, and the key figures end above the traceability table."""
    from ares.batch import certificate
    from ares.analysis.stats.estimate import exact_text

    figs = {f"quantity_{k:02d}": _fig(1.0 + k, 0.01, "DN") for k in range(70)}
    figs["mu_p_sat"] = _fig(15320.0, 0.0, "photons")
    figs["DR"] = dict(_fig(76.6, None, ""), verdict="lower limit")
    j = judge([{"item": "/l/die0", "status": "done", "kind": "run", "hash": "0" * 64, "sensor": "S0",
                "figures": figs}], [])
    path = str(tmp_path / "r.sqlite")
    with rdb.connect(path) as db:
        rdb.append_lot(db, "L1", j)
        fig, *more = certificate.pages(db, 1, [0])
    assert more  # continued
    texts = [(t.get_position()[1], t.get_text()) for t in fig.texts]
    trace = next(y for y, s in texts if s == "Traceability")
    assert min(y for y, s in texts if s.startswith("quantity_")) > trace
    text = " ".join(t.get_text() for f in (fig, *more) for t in f.texts)  # (wrapped cells: their lines in order)
    assert all(f"quantity_{k:02d}" in text for k in range(70))
    assert f"15320 photons ({exact_text()})" in text and "> 76.6" in text and "76.6 (SE not" not in text


def test_lot_tables_carry_an_exact_figures_why_and_a_limit_as_one(tmp_path):
    """A declared figure (SE 0, "exact": why) is "exact: why" in lot.csv's verdict column, in the
    database and on the certificate and the lot PDF's cell -- not "ok" with a bare SE 0; a limit
    is "> x" there (its verdict column "lower limit")."""
    import csv as _csv
    import io

    from ares.analysis.stats.estimate import EXACT_PHOTONS, exact_text
    from ares.batch import certificate
    from ares.batch.lot_pdf import _cell
    from ares.batch.lot_report import to_csv

    figs = {"mu_p_sat": dict(_fig(15320.0, 0.0, "photons"), verdict="ok", exact=EXACT_PHOTONS),
            "DR": dict(_fig(76.6, None, ""), verdict="lower limit")}
    j = judge([{"item": "/l/die0", "status": "done", "kind": "run", "hash": "0" * 64, "sensor": "S0",
                "figures": figs}], [])
    row = next(_csv.DictReader(io.StringIO(to_csv(j, "L1"))))
    assert row["mu_p_sat_verdict"] == exact_text(EXACT_PHOTONS) and row["mu_p_sat_se"] == "0.0"
    assert row["DR_verdict"] == "lower limit"
    assert _cell(j.results[0], "mu_p_sat") == f"15320 photons ({exact_text(EXACT_PHOTONS)})"
    assert _cell(j.results[0], "DR") == "> 76.6"
    path = str(tmp_path / "r.sqlite")
    with rdb.connect(path) as db:
        rdb.append_lot(db, "L1", j)
        back = rdb.figures(db, 1)[0]
        fig, *_ = certificate.pages(db, 1, [0])
    assert back["mu_p_sat"]["verdict"] == exact_text(EXACT_PHOTONS)
    text = " ".join(t.get_text() for t in fig.texts)
    assert f"15320 photons ({exact_text(EXACT_PHOTONS)})" in text and "> 76.6" in text


def test_lot_statistics_find_every_key_and_keep_limits_apart():
    """A figure keyed by its path (``emva4.values.K``: its canonical form names another key) is
    found for the lot's statistics; a figure known only as a limit is not a value of the
    median/IQR/min/max (counted in its own column)."""
    from ares.batch.lot_pdf import _stats
    from ares.batch.lot_report import find

    res = [{"item": f"/l/d{i}", "status": "done", "kind": "run", "hash": f"{i:064x}",
            "figures": {"emva4.values.K": _fig(0.40 + 0.01 * i, 1e-4, "DN/e-"),
                        "dsnu_e": dict(_fig(9.0, None, "e-"), verdict="upper limit") if i == 2 else
                        _fig(1.0 + i, 0.01, "e-")}} for i in range(3)]
    assert find(res[0]["figures"], "emva4.values.K")["value"] == 0.40
    rows = {r[1]: r[1:] for r in _stats(judge(res, []))}  # (r[0]: the quantity's label, r[1] its lot.csv column)
    assert rows["emva4.values.K"][1:3] == ["3", "0.41"]
    assert rows["dsnu_e"][1:3] == ["2", "1.5"] and rows["dsnu_e"][5] == "2" and rows["dsnu_e"][7] == "1"


def test_database_statistics_leave_limits_out(tmp_path):
    """``lots compare``'s medians and ``lots trend``'s values are of measured figures: one known
    only as a limit is not among them."""
    res = [{"item": f"/l/d{i}", "status": "done", "kind": "run", "hash": f"{i:064x}",
            "figures": {"dsnu_e": dict(_fig(9.0, None, "e-"), verdict="upper limit") if i == 2 else
                        _fig(1.0 + i, 0.01, "e-")}} for i in range(3)]
    with rdb.connect(str(tmp_path / "r.sqlite")) as db:
        lot = rdb.append_lot(db, "L1", judge(res, []))
        assert rdb.quantity_stats(db, lot)["dsnu_e"][:2] == (2, 1.5)
        assert sorted(rdb.values(db, lot, "dsnu_e")) == [1.0, 2.0]
