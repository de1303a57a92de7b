"""The report PDF drawn by two processes (``ares.report.pdf_parts``) is the report one
process draws: same pages, same text, in order; a helper that fails or plans another
run is replaced by this process."""

from __future__ import annotations

from pathlib import Path

import pytest
from pypdf import PdfReader

from ares.protocol import load_scan
from ares.report import pdf_parts, write_reports
from ares.scan import Runner

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    sc = load_scan(SMALL / "ptc_small.xml")
    base = tmp_path_factory.mktemp("parts")
    dirs = []
    for seed in (3, 4):
        out = Runner(sc, out_dir=base / f"run{seed}", seed=seed, defer_reports=True).run()
        assert out.status == "done"
        dirs.append(out.run_dir)
    return dirs


def _texts(path: Path) -> list[str]:
    return [p.extract_text() for p in PdfReader(path).pages]


def _one_process(run_dir: Path, tmp: Path, monkeypatch) -> list[str]:
    monkeypatch.setenv("ARES_PDF_HELPER", "0")
    write_reports(run_dir, ("pdf",), pdf_path=tmp / "one.pdf")
    monkeypatch.delenv("ARES_PDF_HELPER")
    return _texts(tmp / "one.pdf")


def test_two_processes_draw_the_same_report(runs, tmp_path, monkeypatch):
    ref = _one_process(runs[0], tmp_path, monkeypatch)
    assert len(ref) >= pdf_parts.MIN_PAGES
    helper = pdf_parts.start(runs[0])
    assert helper is not None
    write_reports(runs[0], ("pdf",), pdf_path=tmp_path / "two.pdf", helper=helper)
    assert helper.proc.returncode == 0  # it drew its share
    two = _texts(tmp_path / "two.pdf")
    assert two == ref
    assert not list(tmp_path.glob("*.tmp*"))  # the part files are gone


def test_a_helper_for_another_run_is_not_used(runs, tmp_path, monkeypatch):
    ref = _one_process(runs[0], tmp_path, monkeypatch)
    helper = pdf_parts.start(runs[1])  # same scan, other run: same titles, other numbers
    write_reports(runs[0], ("pdf",), pdf_path=tmp_path / "r.pdf", helper=helper)
    assert helper.proc.returncode == 3
    assert _texts(tmp_path / "r.pdf") == ref


def test_a_dead_helper_is_replaced(runs, tmp_path, monkeypatch):
    ref = _one_process(runs[0], tmp_path, monkeypatch)
    helper = pdf_parts.start(runs[0])
    helper.proc.kill()
    write_reports(runs[0], ("pdf",), pdf_path=tmp_path / "r.pdf", helper=helper)
    assert _texts(tmp_path / "r.pdf") == ref


def test_split_balances_the_pages():
    titles = ["title", "ptc x1", "snr x1", "components", "views", "maps a", "maps dark", "defects", "stages"]
    mine, theirs = pdf_parts.split(titles)
    assert sorted(mine + theirs) == list(range(len(titles))) and not set(mine) & set(theirs)
    load = [sum(pdf_parts.weight(titles[i]) for i in part) for part in (mine, theirs)]
    assert abs(load[0] - load[1]) <= max(pdf_parts.WEIGHTS.values())
    mine, theirs = pdf_parts.split(titles, 0.0, 100.0)  # a helper that starts late gets nothing
    assert theirs == []
