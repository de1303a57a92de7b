"""After Stop the window says "kept in DIR" only with the run's reports complete (issue
38: the message came 4 s before the PDF in that directory was): first "writing its
reports…", then -- once run.json says the reports are complete and report.pdf is there --
the final message."""

from __future__ import annotations

import json
import os

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from test_gui import TIMEOUT_MS, ptc_small_with, run_to_end, window  # noqa: E402,F401 (fixture)
from test_gui_stopped_truth import _stopping_job  # noqa: E402

from ares.gui.models import progress as P  # noqa: E402

pytestmark = pytest.mark.gui


def _state(run_dir: str) -> str | None:
    try:
        return json.loads(open(os.path.join(run_dir, "run.json")).read()).get("reports")
    except (OSError, ValueError):
        return None


def test_stopped_message_waits_for_the_runs_reports(window, qtbot, tmp_path):  # noqa: F811
    scan = ptc_small_with(tmp_path, '<output raw_frames="false" hdf5="false" csv="false" pdf="true"/>')  # the PDF only
    window.controls.output.directory.setText(str(tmp_path))
    window.set_job_factory(lambda: _stopping_job(scan, 4), scan)
    seen = []  # (message, report.pdf there?, run.json's reports) at the moment each is shown

    def shown(message: str) -> None:
        run_dir = window.session.info.items.get("run directory", "")
        if "kept in" in message:
            seen.append((message, os.path.isfile(os.path.join(run_dir, "report.pdf")), _state(run_dir)))

    window.statusBar().messageChanged.connect(shown)
    run_to_end(qtbot, window)
    qtbot.waitUntil(lambda: seen and not seen[-1][0].endswith("writing its reports…"), timeout=TIMEOUT_MS)
    assert window.session.progress.state == P.STOPPED
    assert seen[0][0].endswith("writing its reports…"), seen  # said at once, and what is still to come
    final = [s for s in seen if not s[0].endswith("writing its reports…")]
    assert final, seen
    for message, pdf, state in final:  # whenever the window says the run is kept, its reports are there
        assert message.endswith("its reports are complete."), message
        assert pdf and state == "complete", (message, pdf, state)
    assert window.statusBar().currentMessage() == final[-1][0]
    assert window.session.progress.message == final[-1][0]
