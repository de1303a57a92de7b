"""The README's production workflow, run as written (a study: three lots of 200 simulated
sensors, a few minutes on 2 cores): its ``sh`` block under "### Production workflow" is run
by bash in an empty folder -- ``python -m ares.batch.demo``, a real ``dask scheduler`` and
``dask worker``, ``ares batch`` into SQLite and PostgreSQL by URL, ``ares lots list``,
``export --stdf``, ``certificate``, ``trend``. Two substitutions only: the PostgreSQL URL
becomes the pgserver the suite starts (skipped, saying why, where it cannot start), port
8786 a free one. Then everything checked against the demo's planted truth: the bins in
lot.csv and in both databases, STDF read back with pystdf (a PRR per sensor with its bins,
4 wafers, HBR/SBR counts and the declared names), a certificate page per sensor, the trend
over the three lots. The suite's small version: tests/test_lots_production.py."""

from __future__ import annotations

import csv
import os
import re
import socket
import subprocess
from pathlib import Path

import pytest

from test_lots import postgres  # noqa: F401 -- the PostgreSQL fixture

ROOT = Path(__file__).resolve().parents[1]
README_PG = "postgresql+psycopg://ares@localhost/lots"


def readme_workflow() -> str:
    text = (ROOT / "README.md").read_text()
    m = re.search(r"### Production workflow\n.*?```sh\n(.*?)```", text, re.S)
    assert m, "README.md: no sh block under '### Production workflow'"
    return m.group(1)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_readme_workflow_block_is_what_this_study_runs():
    """(In the suite, cheap: the block is there and uses what the study substitutes.)"""
    block = readme_workflow()
    assert README_PG in block and "tcp://127.0.0.1:8786" in block and "--port 8786" in block
    for cmd in ("python -m ares.batch.demo", "ares batch", "ares lots export", "--stdf", "ares lots certificate",
                "ares lots trend", "sqlite:///"):
        assert cmd in block, cmd


@pytest.mark.study
def test_the_readme_production_workflow_runs_as_written(tmp_path, postgres):  # noqa: F811
    pytest.importorskip("pystdf")
    from pdftext import page_count, pdf_text
    from test_lots_stdf import read_stdf

    from ares.batch import db as rdb

    pg = postgres.replace("postgresql://", "postgresql+psycopg://", 1)
    port = _free_port()
    script = readme_workflow().replace(README_PG, pg).replace("8786", str(port))
    (tmp_path / "workflow.sh").write_text(script)
    bin_dir = Path(os.sys.executable).parent
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PATH": f"{bin_dir}:{os.environ['PATH']}"}
    p = subprocess.run(["bash", "workflow.sh"], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=3600, start_new_session=True)
    assert "Traceback" not in p.stderr, p.stderr[-3000:]
    assert "database is locked" not in p.stderr
    for lot in ("P1", "P2", "P3"):
        assert f"lot {lot}: 200 item(s)" in p.stdout, p.stdout[-3000:]
    truth = {r["serial"]: r for r in csv.DictReader((tmp_path / "demo" / "truth_P1.csv").open())}
    rows = {r["serial"]: r for r in csv.DictReader((tmp_path / "lots" / "P1" / "lot.csv").open())}
    assert set(rows) == set(truth) and len(truth) == 200
    for s, t in truth.items():
        assert (rows[s]["hard_bin"], rows[s]["soft_bin"]) == (t["hard_bin"], t["soft_bin"]), s
    for target in (f"sqlite:///{tmp_path}/results/lots.db", pg):
        with rdb.connect(target) as db:
            assert [r["name"] for r in rdb.lots(db)][-3:] == ["P1", "P2", "P3"]
            cols, items = rdb.item_rows(db, rdb.find_lot(db, "P1"))
            got = {dict(zip(cols, r))["serial"]: dict(zip(cols, r)) for r in items}
            assert {s: (str(r["hard_bin"]), str(r["soft_bin"])) for s, r in got.items()} == {
                s: (t["hard_bin"], t["soft_bin"]) for s, t in truth.items()}
    recs = read_stdf(tmp_path / "P1.stdf")
    assert len(recs["PRR"]) == 200 and len(recs["WRR"]) == 4
    assert {(p["PART_ID"], str(p["HARD_BIN"]), str(p["SOFT_BIN"])) for p in recs["PRR"]} == {
        (s, t["hard_bin"], t["soft_bin"]) for s, t in truth.items()}
    counts = {}
    for t in truth.values():
        counts[int(t["hard_bin"])] = counts.get(int(t["hard_bin"]), 0) + 1
    assert {b["HBIN_NUM"]: (b["HBIN_NAM"], b["HBIN_CNT"]) for b in recs["HBR"]} == {
        n: (name, counts.get(n, 0)) for n, name in ((1, "good"), (2, "parametric fail"), (3, "outlier"), (4, "no data"))}
    assert page_count(tmp_path / "P1_certificates.pdf") == 200
    assert "hard 3 (outlier, fail), soft 51: noise outlier" in pdf_text(tmp_path / "certificates_P1_P1-0007.pdf")
    trend = list(csv.DictReader((tmp_path / "trend_o.csv").open()))
    assert [t["lot"] for t in trend] == ["P1", "P2", "P3"] and (tmp_path / "trend_o.png").stat().st_size > 0
