"""Shared test fixtures."""

import sys

from ares.cli import set_blas_threads

# The suite's processes (its xdist workers, the commands it starts) run with the BLAS threads
# `ares` itself runs with (one): set before numpy is first imported, or OpenBLAS starts a
# thread per core in each worker, and its multithreaded level-1 calls (np.dot of a frame's
# 19200 pixels: ~1 ms with two workers on two cores, 2 us on one thread) made
# test_emva4_truth.py take 67 s of CPU instead of 10 (benchmarks/suite_time.md).
if "numpy" in sys.modules:  # (a plugin imported it: the setting below reaches only the commands started)
    import warnings

    warnings.warn("numpy was imported before tests/conftest.py set the BLAS threads to ARES's: the suite is slower")
set_blas_threads()

import os  # noqa: E402

# The report PDF's second process (ares.report.pdf_parts: a helper that imports matplotlib and
# the report modules and draws half the pages) buys wall time only on an idle second core; in
# the suite both cores run xdist workers, so each helper only added its start-up (~2 s of CPU
# per report: test_report.py 38.5 -> 31.1 s CPU). Off here (and in the commands the tests
# start, which inherit it) unless the environment says otherwise; the helper itself is tested
# where it is the subject: test_report_parts.py, test_cli_run.py's with/without case, and the
# SIGKILL/signal cases of test_signal_campaign.py / test_signal_sweep.py (their runs keep it on).
os.environ.setdefault("ARES_PDF_HELPER", "0")

import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

# property tests draw their examples from a fixed seed: the suite passes or fails the same way on
# every run (a failure found once is kept in a test of its own, not left to chance)
settings.register_profile("ares", derandomize=True)
settings.load_profile("ares")


@pytest.fixture(scope="module")
def report(request):
    """Lines a statistical test wants shown (bias tables, confusion matrices): printed at
    the end of the module even when pytest captures output, so the test log carries them."""
    lines: list[str] = []
    yield lines
    capman = request.config.pluginmanager.getplugin("capturemanager")
    with capman.global_and_fixture_disabled():
        for line in lines:
            print(line)


@pytest.fixture(scope="session")
def shared_run(tmp_path_factory):
    """``shared_run(key, argv)``: ``ares <argv> --out DIR`` run once for the whole test
    session, across the xdist workers (the first to ask runs it under a file lock, the others
    wait and read it); returns (DIR, its exit code, what it printed). For the long scans more
    than one module checks (scans/emva_reference.xml: ~60 s a run). The run directory is
    read-only to the tests."""
    import contextlib
    import fcntl
    import io
    import json

    base = tmp_path_factory.getbasetemp()
    root = (base.parent if base.name.startswith("popen-gw") else base) / "shared_runs"
    root.mkdir(exist_ok=True)

    def get(key: str, argv: list[str]):
        from ares.cli import main

        out, said = root / key, root / f"{key}.json"
        with open(root / f"{key}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
            if not said.is_file():
                buf = io.StringIO()
                with contextlib.redirect_stdout(buf):
                    rc = main([*argv, "--out", str(out)])
                said.write_text(json.dumps({"rc": rc, "terminal": buf.getvalue()}))
        d = json.loads(said.read_text())
        return out, d["rc"], d["terminal"]

    return get


@pytest.fixture(scope="session")
def ptc_small_no_pdf(tmp_path_factory):
    """fixtures/xml/small/ptc_small.xml without its PDF, beside its system file (one copy a
    worker): for tests that check statuses, stages, results, CSVs or the terminal but never
    read the PDF, which was most of each such run's time; the report's tests read it."""
    from pathlib import Path

    small = Path(__file__).resolve().parents[1] / "fixtures" / "xml" / "small"
    d = tmp_path_factory.mktemp("ptc_small_no_pdf")
    (d / "sim_small.xml").write_text((small / "sim_small.xml").read_text())
    text = (small / "ptc_small.xml").read_text()
    assert '<output raw_frames="true"/>' in text
    (d / "ptc_small.xml").write_text(text.replace('<output raw_frames="true"/>', '<output raw_frames="true" pdf="false"/>'))
    return d / "ptc_small.xml"
