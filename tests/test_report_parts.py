"""The report PDF drawn by two processes (``ares.report.pdf_parts``) is the report one
process draws: same pages, same text, in order; a helper that fails or plans another
run is replaced by this process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from pypdf import PdfReader

from ares.protocol import load_scan
from ares.report import pdf_parts, write_reports
from ares.scan import Runner

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small"


@pytest.fixture(autouse=True)
def helper_on(monkeypatch):
    """The helper is what these tests test (tests/conftest.py turns it off elsewhere)."""
    monkeypatch.setenv("ARES_PDF_HELPER", "1")


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


@pytest.fixture(scope="module")
def ref(runs, tmp_path_factory) -> list[str]:
    """The pages' text of runs[0]'s report drawn by one process (no helper): what every
    report drawn by two must equal (drawn once for the module)."""
    out = tmp_path_factory.mktemp("one") / "one.pdf"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ARES_PDF_HELPER", "0")
        write_reports(runs[0], ("pdf",), pdf_path=out)
    return _texts(out)


def test_pages_drawn_by_two_processes_merge_into_the_report(runs, tmp_path, ref):
    import matplotlib

    from ares.report import pdf, plots
    from ares.report.source import read_run

    run = read_run(runs[0])
    with matplotlib.rc_context(plots.RC):
        pages = pdf.page_plan(run)
    n = len(pages)
    assert n == len(ref) >= pdf_parts.MIN_PAGES
    work = tmp_path / "work"
    work.mkdir()
    mine = [0, 2, n - 1]  # claimed here first
    for i in mine:
        (work / f"claim{i:03d}").touch()
    helper = pdf_parts.start(runs[0])
    helper.go(work)
    assert helper.wait()
    theirs = json.loads((work / "helper.json").read_text())["pages"]
    assert sorted(theirs) == [i for i in range(n) if i not in mine]
    assert theirs == [i for i in pdf_parts.claim_order([t for t, _ in pages]) if i not in mine]  # heaviest first
    pdf.render(run, pages, mine, work / "main.pdf")
    pdf_parts.merge(n, [(work / "main.pdf", mine), (work / "helper.pdf", theirs)], tmp_path / "two.pdf", "x")
    assert _texts(tmp_path / "two.pdf") == ref
    helper.close()


def test_a_helper_left_no_page_ends_normally(runs, tmp_path):
    """Every page claimed here before the helper was ready (a short report, a slow
    helper): it draws nothing, says so, and exits 0 -- the report is not redrawn."""
    import matplotlib

    from ares.report import pdf, plots
    from ares.report.source import read_run

    run = read_run(runs[0])
    with matplotlib.rc_context(plots.RC):
        titles = [t for t, _ in pdf.page_plan(run)]
    work = tmp_path / "work"
    work.mkdir()
    for i in range(len(titles)):
        (work / f"claim{i:03d}").touch()
    helper = pdf_parts.start(runs[0])
    helper.go(work)
    assert helper.wait(), helper.proc.returncode
    assert pdf_parts._helper_part(work, pdf_parts.fingerprint(titles, run.dir)) == []
    assert not (work / "helper.pdf").exists() and not (work / "helper.pdf.tmp").exists()
    helper.close()


def test_write_reports_with_a_helper_gives_the_same_report(runs, tmp_path, ref):
    helper = pdf_parts.start(runs[0])
    assert helper is not None
    write_reports(runs[0], ("pdf",), pdf_path=tmp_path / "two.pdf", helper=helper)
    assert helper.proc.returncode == 0
    assert _texts(tmp_path / "two.pdf") == ref
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two.pdf"]  # no part files left


def test_a_helper_for_another_run_is_not_used(runs, tmp_path, ref):
    helper = pdf_parts.start(runs[1])  # same scan, other run: same titles, other numbers
    write_reports(runs[0], ("pdf",), pdf_path=tmp_path / "r.pdf", helper=helper)
    assert _texts(tmp_path / "r.pdf") == ref


def test_a_dead_helper_is_replaced(runs, tmp_path, ref):
    helper = pdf_parts.start(runs[0])
    helper.proc.kill()
    write_reports(runs[0], ("pdf",), pdf_path=tmp_path / "r.pdf", helper=helper)
    assert _texts(tmp_path / "r.pdf") == ref


def test_claim_order_is_heaviest_first():
    titles = ["title", "ptc x1", "snr x1", "components", "maps a", "maps dark", "stages"]
    order = pdf_parts.claim_order(titles)
    assert sorted(order) == list(range(len(titles)))
    w = [pdf_parts.weight(titles[i]) for i in order]
    assert w == sorted(w, reverse=True) and titles[order[0]].startswith("maps")
