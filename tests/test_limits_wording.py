"""What a run says about its limits (issue 34): "none set" when the scan sets none, "not
checked" for a run that stopped before the end, never "all passed" in either case -- the
same line in ``ares run``'s output, its JSON, the run's scan_results.json and the report."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from ares.cli import main
from ares.protocol import load_scan
from ares.report.source import read_run
from ares.scan import Runner, events as ev
from ares.results.registry import limits_verdict

ROOT = Path(__file__).resolve().parents[1]
PTC = ROOT / "fixtures" / "xml" / "small" / "ptc_small.xml"  # sets one limit (read_noise_e max 50)


def test_verdict_cases():
    assert limits_verdict("done", 0, [])["state"] == "none set"
    assert limits_verdict("stopped", 0, [])["state"] == "none set"
    assert limits_verdict("stopped", 2, [])["state"] == "not checked"
    assert limits_verdict("done", 2, ["x = 3 is not <= 2"])["state"] == "failed"
    assert limits_verdict("done", 2, [])["text"] == "limits: all 2 passed"
    for st, n in (("done", 0), ("stopped", 2), ("aborted", 1)):
        assert "passed" not in limits_verdict(st, n, [])["text"]


def test_scan_without_limits_says_none_set(tmp_path, capsys):
    shutil.copy(PTC.parent / "sim_small.xml", tmp_path / "sim_small.xml")
    text = PTC.read_text()
    xml = tmp_path / "nolimits.xml"
    xml.write_text(text[:text.index("  <limits>")] + text[text.index("</limits>") + len("</limits>\n"):])
    assert main(["run", str(xml), "--out", str(tmp_path / "r"), "--quiet", "--frames", "2"]) == 0
    out = capsys.readouterr().out
    assert "limits: none set" in out and "passed" not in out
    rec = json.loads((tmp_path / "r" / "scan_results.json").read_text())
    assert rec["limits"]["state"] == "none set"
    assert read_run(tmp_path / "r").limits["state"] == "none set"


def test_stopped_run_says_not_checked(tmp_path, ptc_small_no_pdf):
    r = Runner(load_scan(ptc_small_no_pdf), out_dir=tmp_path / "run")

    def listener(e):
        if isinstance(e, ev.FramePreview) and e.index == 2 and e.frame == 1 and not e.dark:
            r.stop()

    r.add_listener(listener)
    out = r.run()
    assert out.status == "stopped"
    rec = json.loads((tmp_path / "run" / "scan_results.json").read_text())
    assert rec["limits"]["state"] == "not checked" and "passed" not in rec["limits"]["text"]
    assert read_run(tmp_path / "run").limits["state"] == "not checked"
