"""The lot's vocabulary, verdicts and yields (judged against hand-counted truth), the results
database (SQLite and a real PostgreSQL started here from the ``pgserver`` package: a
1000-item lot lands in both with identical rows), ``ares lots`` and the lot PDF listing
every item."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from ares.batch import db as rdb
from ares.batch.lot_report import judge, to_csv
from ares.batch.vocabulary import canonical_figures
from ares.cli import main
from ares.protocol.scan import Limit

N_LOT = 1000


def _fig(v, se, unit):
    return {"label": "", "value": v, "se": se, "unit": unit, "verdict": "", "note": ""}


def synthetic_lot(n: int, seed: int = 3) -> list[dict]:
    """``n`` item results as workers return them: run items (photon-transfer names), EMVA
    items (Release 4.0 symbols, renamed by the vocabulary), and every 97th one errored."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        r = {"item": f"/lots/w1/die_{i:04d}", "ares_version": "t", "started": "2026-01-01T00:00:00+00:00",
             "hash": f"{i:064x}", "cached": False}
        if i % 97 == 5:
            out.append({**r, "status": "error", "error": f"/lots/w1/die_{i:04d}: corrupt: stage 2"})
            continue
        k, rn = float(rng.normal(0.3, 0.02)), float(rng.normal(3.0, 0.3))
        if i % 2:
            figs = {"gain_dn_per_e": _fig(k, 1e-3, "DN/e-"), "read_noise_e": _fig(rn, 0.05, "e-")}
            out.append({**r, "kind": "run", "status": "done", "figures": figs})
        else:
            figs = canonical_figures({"K": _fig(k, 1e-3, "DN/e-"), "QE": _fig(50.0, 1.0, "%")})
            out.append({**r, "kind": "emva", "status": "done", "figures": figs})
    return out


def test_one_vocabulary_not_tested_and_yield_denominator():
    res = synthetic_lot(200)
    limits = [Limit("K", min=0.28, max=0.32), Limit("read_noise_e", max=3.2)]
    j = judge(res, limits, {r["item"]: {"sensor": f"S{i}", "x": i % 20, "y": i // 20} for i, r in enumerate(res)})
    # truth, counted here from the raw values: K and gain_dn_per_e are one quantity
    errored = [r for r in res if r["status"] == "error"]
    gains = [r["figures"]["gain_dn_per_e"]["value"] for r in res if r["status"] == "done"]
    assert all("symbol" in r["figures"]["gain_dn_per_e"] for r in res if r.get("kind") == "emva")
    assert j.yields["gain_dn_per_e >= 0.28 and <= 0.32"] == (sum(0.28 <= g <= 0.32 for g in gains), len(res))
    noise = [r["figures"]["read_noise_e"]["value"] for r in res if r.get("kind") == "run"]
    assert j.yields["read_noise_e <= 3.2"] == (sum(v <= 3.2 for v in noise), len(res))
    emva = next(r for r in res if r.get("kind") == "emva")
    assert emva["checks"]["read_noise_e <= 3.2"] is None  # not tested: an EMVA item has no read_noise_e here
    inside = 0.28 <= emva["figures"]["gain_dn_per_e"]["value"] <= 0.32
    assert emva["passed"] is inside  # "not tested" does not fail the item
    assert len(errored) == 3 and all(r["passed"] is False for r in errored)
    rows = list(csv.DictReader(to_csv(j, "w1").splitlines()))
    e = next(r for r in rows if r["item"] == emva["item"])
    assert e["read_noise_e <= 3.2"] == "not tested" and e["verdict"] == ("pass" if inside else "FAIL")
    assert rows[0]["serial"] == "S0" and rows[0]["lot"] == "w1" and rows[0]["content_hash"] == f"{0:064x}"
    # without limits nothing passes or fails
    j0 = judge(synthetic_lot(10), [])
    verdicts = [r["verdict"] for r in csv.DictReader(to_csv(j0).splitlines())]
    assert j0.yields == {} and verdicts == ["no limits set"] * 5 + ["error"] + ["no limits set"] * 4


def _lot(n: int):
    res = synthetic_lot(n)
    return judge(res, [Limit("gain_dn_per_e", min=0.28, max=0.32), Limit("read_noise_e", max=3.2)],
                 {r["item"]: {"sensor": f"SN{i:05d}", "x": float(i % 32), "y": float(i // 32)}
                  for i, r in enumerate(res)})


def _same(a, b) -> bool:
    return all(x == y or (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y))
               for x, y in zip(a, b)) and len(a) == len(b)


def test_sqlite_schema_migrations_and_lots_command(tmp_path, capsys):
    j = _lot(300)
    path = str(tmp_path / "r.sqlite")
    with rdb.connect(path) as db:
        assert rdb.version(db) == rdb.SCHEMA_VERSION
        a = rdb.append_lot(db, "w1", j)
        b = rdb.append_lot(db, "w2", _lot(120))
    assert (a, b) == (1, 2)
    with rdb.connect(path) as db:  # reopening migrates nothing and keeps the rows
        cols, rows = rdb.item_rows(db, rdb.find_lot(db, "w1"))
        assert len(rows) == 300
        assert cols[:13] == list(rdb.ITEM_COLUMNS)
        r0 = dict(zip(cols, rows[0]))
        assert r0["serial"] == "SN00000" and r0["content_hash"] == f"{0:064x}" and r0["x"] == 0.0
        assert r0["gain_dn_per_e"] == j.results[0]["figures"]["gain_dn_per_e"]["value"]
        listed = rdb.lots(db)
    passed = sum(r["passed"] is True for r in j.results)
    assert listed[0]["passed"] == passed and listed[0]["errors"] == sum(r["status"] == "error" for r in j.results)
    assert main(["lots", "list", "--db", path]) == 0
    out = capsys.readouterr().out
    assert f"yield {passed}/300" in out and "w2" in out
    assert main(["lots", "compare", "w1", "w2", "--db", path]) == 0
    assert "gain_dn_per_e" in capsys.readouterr().out
    assert main(["lots", "export", "w1", "--db", path, "--csv", str(tmp_path / "w1.csv")]) == 0
    exported = list(csv.DictReader((tmp_path / "w1.csv").open()))
    assert len(exported) == 300 and exported[5]["verdict"] == "error" and "corrupt: stage 2" in exported[5]["error"]
    assert main(["lots", "export", "nope", "--db", path]) == 2
    # a database written by a newer ARES is refused in one sentence
    import sqlite3

    c = sqlite3.connect(path)
    c.execute("UPDATE alembic_version SET version_num = '9999'")
    c.commit()
    c.close()
    assert main(["lots", "list", "--db", path]) == 2
    assert "newer than this ARES" in capsys.readouterr().err


@pytest.fixture(scope="module")
def postgres(tmp_path_factory):
    try:
        import pgserver
        import psycopg  # noqa: F401
    except ImportError as exc:
        pytest.skip(f"PostgreSQL test needs pgserver and psycopg ({exc})")
    import tempfile

    srv, why = None, ""
    for _ in range(2):  # a fresh data directory each try, outside pytest's rotating tmp dirs
        try:
            srv = pgserver.get_server(tempfile.mkdtemp(prefix="ares_pg_"), cleanup_mode="delete")
            break
        except Exception as exc:  # noqa: BLE001 -- the server could not start on this machine
            why = str(exc)
    if srv is None:
        pytest.skip(f"pgserver could not start a PostgreSQL server here: {why}")
    yield srv.get_uri()
    srv.cleanup()


def test_1000_item_lot_lands_identically_in_sqlite_and_postgresql(postgres, tmp_path):
    j = _lot(N_LOT)
    got = {}
    for name, target in (("sqlite", str(tmp_path / "r.sqlite")), ("postgresql", postgres)):
        with rdb.connect(target) as db:
            lot_id = rdb.append_lot(db, "wafer_1000", j)
        with rdb.connect(target) as db:
            got[name] = rdb.item_rows(db, lot_id)
            assert rdb.lots(db)[-1]["items"] == N_LOT
    (ca, ra), (cb, rb) = got["sqlite"], got["postgresql"]
    assert ca == cb and len(ra) == len(rb) == N_LOT
    assert all(_same(a, b) for a, b in zip(ra, rb))
    # and they are the judged lot's own figures (not two copies of one mistake)
    k = ca.index("gain_dn_per_e")
    assert [r[k] for r in ra] == [(r.get("figures") or {}).get("gain_dn_per_e", {}).get("value")
                                  for r in j.results]


@pytest.mark.slow  # 1000 items: ~20 appendix pages and the wafer maps (~40 s on a busy 2-core machine)
def test_lot_pdf_lists_every_item_and_colours_failed_dies(tmp_path):
    from pdftext import pdf_text

    from ares.batch.lot_pdf import write_pdf

    j = _lot(N_LOT)
    write_pdf(j, tmp_path / "lot.pdf", "wafer_1000")
    text = pdf_text(tmp_path / "lot.pdf")
    missing = [r["item"] for r in j.results if r["item"].rsplit("/", 1)[1] not in text]
    assert not missing
    assert "Appendix: every item (1/" in text and "Appendix: every error" in text
    assert "bin per die" in text and "verdict per die" in text and "Yield per limit" in text


def test_parquet_export_has_the_rows_of_the_database_and_the_csv(tmp_path):
    """``ares lots export --parquet``: the lot's rows exactly as the database holds them
    (floats bit for bit, an absent figure null, text as text) and as the CSV export writes
    them, with float64 quantity columns and string traceability/limit columns."""
    import pyarrow.parquet as pq

    path = str(tmp_path / "r.sqlite")
    with rdb.connect(path) as db:
        rdb.append_lot(db, "w1", _lot(200))
        cols, rows = rdb.item_rows(db, rdb.find_lot(db, "w1"))
    pq_file, csv_file = tmp_path / "w1.parquet", tmp_path / "w1.csv"
    assert main(["lots", "export", "w1", "--db", path, "--parquet", str(pq_file), "--csv", str(csv_file)]) == 0
    table = pq.read_table(pq_file)
    assert table.column_names == cols and table.num_rows == len(rows) == 200
    types = {f.name: str(f.type) for f in table.schema}
    assert types["gain_dn_per_e"] == types["gain_dn_per_e_se"] == types["x"] == "double"
    assert types["serial"] == types["verdict"] == "string"
    got = [tuple(r[c] for c in cols) for r in table.to_pylist()]
    assert got == rows  # (None == None for the nulls: errored items and quantities an item kind lacks)
    with csv_file.open() as fh:
        in_csv = list(csv.reader(fh))
    assert in_csv[0] == cols
    for row_csv, row_pq in zip(in_csv[1:], got):
        assert row_csv == ["" if v is None else (repr(v) if isinstance(v, float) else v) for v in row_pq]
    assert sum(v is None for r in got for v in r) > 0  # nulls are exercised, not only full rows


def test_lot_surfaces_name_quantities_by_their_label_and_unit(tmp_path):
    """The lot PDF's tables, its plots, lot_columns.csv, lot.h5 and the certificate call a
    quantity what every scan surface calls it (``ares.labels``: "system gain K", the EMVA 1288
    symbol), with its unit -- the machine key only as the lot.csv column it names."""
    import io

    import h5py

    from ares.batch import certificate
    from ares.batch.lot_pdf import _stats, _summary
    from ares.batch.lot_report import columns_csv, write_h5
    from ares.labels import figure_name

    res = synthetic_lot(40)
    j = judge(res, [Limit("K", min=0.28, max=0.32)])
    stats = {r[1]: r for r in _stats(j)}  # lot.csv column -> row
    assert stats["gain_dn_per_e"][0] == figure_name("gain_dn_per_e") == "system gain K"
    assert stats["QE"][0] == "EMVA 1288 4.0 η" and stats["QE"][7] == "%"
    assert stats["read_noise_e"][0] == figure_name("read_noise_e")
    texts = [t.get_text() for t in _summary(j, "w1").texts]
    assert "system gain K" in texts and "gain_dn_per_e >= 0.28 and <= 0.32" in texts
    cols = {r["column"]: r for r in csv.DictReader(io.StringIO(columns_csv(j, "w1")))}
    assert cols["gain_dn_per_e"]["quantity"] == "system gain K" and cols["gain_dn_per_e"]["unit"] == "DN/e-"
    assert cols["QE_se"]["quantity"] == "SE of EMVA 1288 4.0 η" and cols["QE_se"]["unit"] == "%"
    assert set(cols) == set(next(csv.reader(io.StringIO(to_csv(j, "w1")))))  # every lot.csv column, none more
    write_h5(j, tmp_path / "lot.h5", "w1")
    with h5py.File(tmp_path / "lot.h5") as f:
        assert dict(f["items/gain_dn_per_e"].attrs) == {"label": "system gain K", "unit": "DN/e-"}
    path = str(tmp_path / "r.sqlite")
    with rdb.connect(path) as db:
        rdb.append_lot(db, "w1", j)
        fig, *_ = certificate.pages(db, 1, [1])
    text = " ".join(t.get_text() for t in fig.texts)
    assert "system gain K" in text and "read noise sigma_d (no quant.)" in text and "gain_dn_per_e" not in text


def test_wafer_maps_draw_every_die_of_every_wafer():
    """Each wafer numbers its own dies: two wafers' dies at one (x, y) were drawn one over the
    other (a failed die hidden under a passing one). Side by side, every die has its own place."""
    from ares.batch.lot_pdf import _side_by_side

    placed = [{"wafer": w, "x": float(x), "y": float(y)} for w in ("W1", "W2", "W3") for x in range(4) for y in range(3)]
    at, names = _side_by_side(placed)
    assert len({at[id(r)] for r in placed}) == len(placed)  # no two dies at one place
    assert set(names) == {"W1", "W2", "W3"} and names["W2"][0] == 5.0  # (4 columns and a gap of 2)
    one = [{"wafer": "W1", "x": 1.0, "y": 2.0}]
    assert _side_by_side(one)[0][id(one[0])] == (1.0, 2.0) and _side_by_side(one)[1] == {}
