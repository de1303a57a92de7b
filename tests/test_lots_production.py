"""The production workflow end to end: a lot of cheap simulated sensors (``ares.batch.demo``:
a dark stack each, offset ~ N(200, 2) DN, pixel temporal noise 3 DN) across 4 wafers, with
planted truth -- sensors whose offset is outside the static limit, sensors whose temporal
noise is 4x (an outlier only the lot's own dynamic PAT limit catches), one unreadable file
-- and the bins its lot file declares, through
``ares batch`` on a real Dask scheduler into a results database by URL; bins equal to the
truth, lot.stdf and ``ares lots export --stdf`` read back by pystdf equal to lot.csv,
certificates and a trend over three lots.

The normal suite runs 24 sensors into SQLite (no trend: tests/test_lots_certificate_trend.py
has it); the study (``@pytest.mark.study``) 200 into
SQLite and into a real PostgreSQL (pgserver)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from ares.batch import demo
from ares.cli import main
from test_lots import postgres  # noqa: F401 -- the PostgreSQL fixture
from test_lots_stdf import read_stdf

pytest.importorskip("distributed")
pytest.importorskip("pystdf")

@pytest.fixture(scope="module")
def scheduler():
    from ares.batch.cluster import close_client, make_client

    c = make_client(workers=2)
    yield c.scheduler.address
    close_client(c)


def make_lot(base, n: int) -> dict[str, str]:
    return demo.make_lot(base, n, "prod")  # (the generator the README's workflow uses)


WANT_BIN = demo.BIN_OF


def production(base, scheduler, n: int, db: str, capsys, trend: bool = True) -> None:
    truth = make_lot(base, n)
    out = base / "out"
    rc = main(["batch", "--lot", str(base / "prod.xml"), "--out", str(out), "--scheduler", scheduler, "--db", db, "-q"])
    cap = capsys.readouterr()
    assert rc == 1 and "Traceback" not in cap.err and "ares batch: ares batch" not in cap.err, cap.err
    rows = list(csv.DictReader((out / "lot.csv").open()))
    assert len(rows) == n
    for r in rows:  # the bins are the planted truth
        assert (int(r["hard_bin"]), int(r["soft_bin"])) == WANT_BIN[truth[r["serial"]]], r["serial"]
    counts = {k: sum(v == k for v in truth.values()) for k in WANT_BIN}
    for k, (hb, sb) in WANT_BIN.items():
        assert f"bin {hb}/{sb} " in cap.out and f": {counts[k]}/{n}" in cap.out
    # STDF from the batch and from the database: what lot.csv says, as 4-byte floats
    assert main(["lots", "export", "prod", "--db", db, "--stdf", str(base / "db.stdf")]) == 0
    capsys.readouterr()
    for f in (out / "lot.stdf", base / "db.stdf"):
        recs = read_stdf(f)
        prr = {p["PART_ID"]: p for p in recs["PRR"]}
        assert set(prr) == set(truth) and len(recs["WRR"]) == 4
        k = 0
        for p in recs["PRR"]:
            r = next(x for x in rows if x["serial"] == p["PART_ID"])
            assert (p["HARD_BIN"], p["SOFT_BIN"]) == (int(r["hard_bin"]), int(r["soft_bin"]))
            assert (p["X_COORD"], p["Y_COORD"]) == (int(float(r["x"])), int(float(r["y"])))
            for t in recs["PTR"][k:k + p["NUM_TEST"]]:
                if t["TEST_NUM"] < 5000:  # the value and its SE ("<quantity> SE")
                    col = t["TEST_TXT"].replace(" SE", "_se")
                    if r[col] == "":  # an SE not available: "RESULT not valid", not a number
                        assert col.endswith("_se") and t["TEST_FLG"] & 0x02, (p["PART_ID"], t["TEST_TXT"])
                    else:
                        assert t["RESULT"] == float(np.float32(float(r[col]))), (p["PART_ID"], t["TEST_TXT"])
            k += p["NUM_TEST"]
        assert {b["HBIN_NUM"]: b["HBIN_CNT"] for b in recs["HBR"]} == {
            WANT_BIN[kd][0]: c for kd, c in counts.items() if c}
    # a certificate per sensor
    outlier = next(s for s, v in truth.items() if v == "outlier")
    assert main(["lots", "certificate", "prod", outlier, "--db", db, "--out", str(base / "c.pdf")]) == 0
    from pdftext import pdf_text

    text = pdf_text(base / "c.pdf")
    assert f"Certificate of performance: {outlier}" in text and "hard 3 (outlier, fail), soft 51: noise outlier" in text
    if not trend:
        return
    # a trend over three lots (the items come from the cache the second and third time)
    for name in ("prod_b", "prod_c"):
        (base / f"{name}.xml").write_text((base / "prod.xml").read_text().replace('name="prod"', f'name="{name}"'))
        assert main(["batch", "--lot", str(base / f"{name}.xml"), "--out", str(out), "--scheduler", scheduler,
                     "--db", db, "-q"]) == 1
    capsys.readouterr()
    assert main(["lots", "trend", "o", "--db", db, "--out", str(base / "trend.png")]) == 0
    trend = list(csv.DictReader((base / "trend.csv").open()))
    assert [t["lot"] for t in trend][-3:] == ["prod", "prod_b", "prod_c"]
    offsets = [float(r["o"]) for r in rows if r["o"]]
    assert float(trend[-1]["median"]) == pytest.approx(float(np.median(offsets)), rel=1e-12)
    assert trend[-1]["out_of_control"] == "no"


def test_production_lot_into_sqlite_by_url(tmp_path, scheduler, capsys):
    production(tmp_path, scheduler, 24, f"sqlite:///{tmp_path}/results/lots.db", capsys, trend=False)
    assert (tmp_path / "results" / "lots.db").is_file()


@pytest.mark.study
@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_production_lot_of_200_sensors(backend, tmp_path, scheduler, capsys, request):
    db = f"sqlite:///{tmp_path}/lots.db" if backend == "sqlite" else \
        request.getfixturevalue("postgres").replace("postgresql://", "postgresql+psycopg://", 1)
    production(tmp_path, scheduler, 200, db, capsys)


def test_a_normal_end_of_ares_batch_is_quiet(tmp_path):
    """``ares batch`` on its own local cluster, as a user runs it: the terminal shows the
    lot's lines and nothing of the cluster's shutdown (no CommClosedError traceback, no
    "Failed to communicate with scheduler", no doubled prefix)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    rng = np.random.default_rng(3)
    for i in range(3):
        np.save(tmp_path / f"d{i}.npy", (200 + rng.normal(0, 3, (4, 8, 8))).astype(np.uint16))
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root)}
    p = subprocess.run([sys.executable, "-m", "ares.cli", "batch", *(str(tmp_path / f"d{i}.npy") for i in range(3)),
                        "--out", str(tmp_path / "lot"), "--workers", "1", "-q"], capture_output=True, text=True,
                       env=env, cwd=tmp_path, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stderr == "", p.stderr
    assert "lot lot: 3 item(s)" in p.stdout
    p = subprocess.run([sys.executable, "-m", "ares.cli", "batch", "--out", str(tmp_path / "lot")],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert p.returncode == 2 and p.stderr.startswith("ares batch: no items") and "ares batch: ares" not in p.stderr
