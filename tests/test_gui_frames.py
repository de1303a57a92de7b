"""A frame-count control in the Scan tab shortens a scan as `ares run --frames N` does
(issue 38: the window could not), end to end: every stage takes N frames, the run
directory records the override, and "as in the scan" leaves the scan's own count."""

from __future__ import annotations

import json
import os

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from test_gui import ptc_small_with, run_to_end, window  # noqa: E402,F401 (fixture)

from ares.gui.models import progress as P  # noqa: E402

pytestmark = pytest.mark.gui


def test_the_frame_count_control_shortens_the_scan_as_the_cli_frames_option(window, qtbot, tmp_path):  # noqa: F811
    path = ptc_small_with(tmp_path, '<output raw_frames="false" hdf5="false" csv="false" pdf="false"/>')
    assert window.load_scan(path)
    window.controls.output.directory.setText(str(tmp_path / "runs"))
    spin = window.controls.scan.frames
    assert spin.text() == "as in the scan" and window.controls.scan.frame_count() is None
    spin.setValue(2)
    frames = []
    window.session.progress.subscribe(lambda m: m.frames and frames.append(m.frames))
    run_to_end(qtbot, window)
    s = window.session
    assert s.progress.state == P.DONE, s.progress.message
    assert {ev.frames for ev in s.stages.results.values()} == {2}  # every stage, the dark one included
    assert set(frames) == {2}
    run_dir = s.info.items["run directory"]
    meta = json.loads(open(os.path.join(run_dir, "run.json")).read())
    assert meta["frames_override"] == 2  # as `ares run --frames 2` records it

    spin.setValue(spin.minimum())  # back to the scan's own count: the job the next Start runs
    assert window.controls.scan.frame_count() is None
    job = window.job_factory()
    try:
        assert job.runner.frames_override is None and {st.frames for st in job.runner.stages} == {4}
    finally:
        job.discard()
