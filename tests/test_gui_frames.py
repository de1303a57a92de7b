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

from test_gui import PTC_SMALL, run_to_end, window  # noqa: E402,F401 (fixture)

from ares.gui.models import progress as P  # noqa: E402

pytestmark = pytest.mark.gui


def _quick_scan(tmp_path) -> str:
    """ptc_small (4 frames a stage) without the report files: the frame counts are the point."""
    text = open(PTC_SMALL).read().replace('href="sim_small.xml"', f'href="{os.path.dirname(PTC_SMALL)}/sim_small.xml"')
    text = text.replace('<output raw_frames="true"/>', '<output raw_frames="false" hdf5="false" csv="false" pdf="false"/>')
    (tmp_path / "quick.xml").write_text(text)
    return str(tmp_path / "quick.xml")


def test_the_frame_count_control_shortens_the_scan_as_the_cli_frames_option(window, qtbot, tmp_path):  # noqa: F811
    path = _quick_scan(tmp_path)
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

    spin.setValue(spin.minimum())  # back to the scan's own count
    assert window.controls.scan.frame_count() is None
    run_to_end(qtbot, window)
    assert {ev.frames for ev in s.stages.results.values()} == {4}
