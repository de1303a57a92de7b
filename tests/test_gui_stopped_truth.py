"""The window after Stop shows the stopped run's own figures (issue 38): the Information
tab kept the previous run's K, full well and dynamic range next to the stopped run's
directory, the PTC tab showed no fit and Defect Counts stayed empty. Now every result tab
is filled from the stopped run's scan-level results (or cleared, with the reason), and the
limits read "not checked" -- or "none set" when a scan sets none."""

from __future__ import annotations

import json
import os

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from test_gui import PTC_SMALL, TIMEOUT_MS, idle, run_to_end, window  # noqa: E402,F401 (fixture)

from ares.gui.models import progress as P  # noqa: E402

pytestmark = pytest.mark.gui


def _stopping_job(path, after: int):
    from ares.gui.runner_adapter import RunnerJob
    from ares.scan import events as ev

    class StopAfter(RunnerJob):
        """Asks the runner to stop once ``after`` stages are finished (in the runner's
        thread: no race with a fast scan)."""

        seen = 0

        def _on_event(self, e):
            if isinstance(e, ev.StageFinished):
                StopAfter.seen += 1
                if StopAfter.seen == after:
                    self.stop()
            super()._on_event(e)

    return StopAfter(path, frames=3)


def test_after_stop_every_tab_shows_the_stopped_runs_own_figures(window, qtbot, tmp_path,  # noqa: F811
                                                                 ptc_small_no_pdf):
    from ares.gui.runner_adapter import RunnerJob, summarize

    PTC_SMALL = str(ptc_small_no_pdf)  # (the window's figures and scan_results.json: no PDF read)
    window.controls.output.directory.setText(str(tmp_path))
    window.set_job_factory(lambda: RunnerJob(PTC_SMALL, frames=3), PTC_SMALL)
    run_to_end(qtbot, window)
    s = window.session
    assert s.progress.state == P.DONE
    first = dict(s.info.items)
    assert "PTC: full well (charge)" in first and first["limits"] == "all 1 passed"

    window.set_job_factory(lambda: _stopping_job(PTC_SMALL, 5), PTC_SMALL)
    run_to_end(qtbot, window)
    assert s.progress.state == P.STOPPED, s.progress.message
    run_dir = s.info.items["run directory"]
    assert run_dir != first["run directory"]
    qtbot.waitUntil(lambda: (os.path.isfile(os.path.join(run_dir, "scan_results.json"))), timeout=TIMEOUT_MS)
    res = json.loads(open(os.path.join(run_dir, "scan_results.json")).read())["analyses"]
    own = summarize(res)["results"]
    shown = {k: v for k, v in s.info.items.items() if k.startswith("PTC")}
    # the stopped run's figures, as its scan_results.json states them -- none of the first run's
    assert shown == {k: v for k, v in own.items() if k.startswith("PTC")}
    assert s.info.items["limits"].startswith("not checked (the run is stopped")
    ptc = res.get("ptc") or {}
    g = (ptc.get("gain_e_per_dn") or {}).get("value")
    if g is not None:  # the engine fitted the levels the stopped run has: the PTC tab draws that fit
        assert s.ptc.gain_e_per_dn == pytest.approx(g)
    else:
        assert s.ptc.gain_e_per_dn is None or s.ptc.gain_e_per_dn != pytest.approx(first.get("gain", -1))


def test_limits_read_none_set_for_a_scan_without_limits(window, qtbot, tmp_path, ptc_small_no_pdf):  # noqa: F811
    from ares.gui.runner_adapter import RunnerJob

    scan = tmp_path / "nolimits.xml"
    text = open(ptc_small_no_pdf).read()  # (the limits line: no PDF read)
    start, end = text.index("<limits>"), text.index("</limits>") + len("</limits>")
    scan.write_text(text[:start] + text[end:])
    (tmp_path / "sim_small.xml").write_text(open(os.path.join(os.path.dirname(PTC_SMALL), "sim_small.xml")).read())
    window.controls.output.directory.setText(str(tmp_path))
    window.set_job_factory(lambda: RunnerJob(str(scan), frames=3), str(scan))
    run_to_end(qtbot, window)
    assert window.session.progress.state == P.DONE
    assert window.session.info.items["limits"].startswith("none set")
