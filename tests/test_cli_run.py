"""``ares run`` / ``ares rerun`` from the command line: output, exit codes, reproducibility."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from ares.cli import main
from ares.scan import load_run

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small"
PTC = str(SMALL / "ptc_small.xml")


def test_dry_run_lists_every_stage(capsys):
    assert main(["run", str(ROOT / "scans" / "photon_transfer.xml"), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "scan 'photon_transfer' on system 'sim_sensor' (640x480): 26 stages" in out
    lines = [ln for ln in out.splitlines() if ln.strip().split(" ")[0].isdigit()]
    assert len(lines) == 26 and "ptc[24]" in lines[-1] and "light=1e+07" in lines[-1]
    # numbered from 0, as the run directory's files and tables number them (issue 52)
    assert lines[0].split()[0] == "0" and lines[-1].split()[0] == "25"
    assert "+ dark (reused)" in lines[1]
    assert "total: 432 frames, estimated 0:00:05" in out  # 432 x (10 ms + 1 ms readout)


def test_dry_run_touches_nothing(tmp_path, capsys):
    assert main(["run", str(ROOT / "scans" / "bias_sweep_2d.xml"), "--dry-run", "--frames", "2",
                 "--out", str(tmp_path / "x")]) == 0
    assert "bias_map[4,3]" in capsys.readouterr().out and not (tmp_path / "x").exists()


def test_run_prints_summary(tmp_path, ptc_small_no_pdf, capsys):
    PTC = str(ptc_small_no_pdf)  # (the terminal summary; the report line: the next test)
    assert main(["run", PTC, "--out", str(tmp_path / "r"), "--quiet"]) == 0
    out = capsys.readouterr().out
    for words in ("ptc_small: done, 9 stage(s)", "conversion gain", "uV/e-", "read noise", "full well",
                  "noise components at stage", "Pt ", "limits: all 1 passed"):
        assert words in out, words


@pytest.mark.parametrize("helper", ["0", "1"])
def test_run_names_its_report_with_or_without_the_report_helper(tmp_path, capsys, monkeypatch, helper):
    monkeypatch.setenv("ARES_PDF_HELPER", helper)
    assert main(["run", PTC, "--out", str(tmp_path / "r")]) == 0
    out = capsys.readouterr().out
    assert f"report: {tmp_path / 'r' / 'report.pdf'}" in out
    assert (tmp_path / "r" / "report.pdf").stat().st_size > 0
    assert not list((tmp_path / "r").glob("*.parts")) and not list((tmp_path / "r").glob("*.tmp"))


def test_run_json(tmp_path, ptc_small_no_pdf, capsys):
    PTC = str(ptc_small_no_pdf)  # (the JSON's status and results)
    assert main(["run", PTC, "--out", str(tmp_path / "r"), "--quiet", "--json", "--frames", "3"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["status"] == "done" and d["stages"] == 9 and d["seed"] == 7
    assert d["scan_results"]["ptc"]["gain_dn_per_e"]["value"] > 0


def test_invalid_input_exit_2(tmp_path, capsys):
    assert main(["run", str(ROOT / "fixtures" / "xml" / "broken" / "frames_not_integer.xml")]) == 2
    assert "frames_not_integer.xml:4: <frames> must be an integer >= 2, got 'ten'" in capsys.readouterr().err
    assert main(["run", PTC, "--frames", "1"]) == 2
    assert main(["run", PTC, "--system", str(tmp_path / "none.xml")]) == 2
    assert main(["run", PTC, "--system", str(ROOT / "protocols" / "sim_sensor.xml"), "--dry-run"]) == 0


def test_failed_limits_exit_4(tmp_path, capsys):
    assert main(["run", str(SMALL / "bias_small.xml"), "--out", str(tmp_path / "r"), "-q"]) == 4
    assert "limit(s) failed" in capsys.readouterr().err
    assert load_run(tmp_path / "r").meta["status"] == "done"


def test_the_ares_script_ends_without_teardown_and_loses_nothing(tmp_path):
    """``python -m ares.cli`` (the script's ``console``) ends a run with os._exit: the exit
    code, every line of stdout and stderr (through pipes) and the run directory's files
    are all there."""
    out = tmp_path / "r"
    p = subprocess.run([sys.executable, "-m", "ares.cli", "run", str(SMALL / "bias_small.xml"), "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)},
                       timeout=900)
    assert p.returncode == 4, p.stderr
    assert "limit(s) failed" in p.stderr and f"run directory: {out}" in p.stdout
    assert p.stdout.rstrip().splitlines()[-1].startswith("report: ")
    rec = load_run(out)
    assert rec.meta["status"] == "done" and (out / "report.pdf").stat().st_size > 0
    assert json.loads((out / "run.json").read_text())["status"] == "done"


def test_hardware_fault_exit_3(tmp_path, capsys):
    rc = main(["run", PTC, "--out", str(tmp_path / "r"), "-q", "--sim-fault", "disconnect_after_frames=20"])
    err = capsys.readouterr().err.strip()
    assert rc == 3
    assert err.count("\n") == 0 and "device disconnected after 20 frames" in err
    rec = load_run(tmp_path / "r")  # (how many stages the 20 frames covered depends on the probe frames settling took)
    assert rec.meta["status"] == "failed" and len(rec.stages) >= 1
    assert f"{len(rec.stages)} completed stage(s) saved in" in err


def test_rerun_reproduces_the_run(tmp_path, ptc_small_no_pdf, capsys):
    PTC = str(ptc_small_no_pdf)
    assert main(["run", PTC, "--out", str(tmp_path / "a"), "-q", "--seed", "11", "--frames", "3"]) == 0
    capsys.readouterr()
    assert main(["rerun", str(tmp_path / "a"), "--out", str(tmp_path / "b"), "-q"]) == 0
    assert "reproduced: 9 of 9 stage result(s) identical" in capsys.readouterr().err
    a, b = load_run(tmp_path / "a"), load_run(tmp_path / "b")
    assert b.meta["seed"] == 11 and b.meta["frames_override"] == 3
    assert a.meta["scan_sha256"] == b.meta["scan_sha256"] and a.meta["system_sha256"] == b.meta["system_sha256"]
    strip = lambda st: [{k: v for k, v in s.items() if k != "timing"} for s in st]
    assert strip(a.stages) == strip(b.stages)
    ra = json.loads((tmp_path / "a" / "scan_results.json").read_text())
    rb = json.loads((tmp_path / "b" / "scan_results.json").read_text())
    assert ra == rb
    # default output directory of a rerun sits next to the original
    assert main(["rerun", str(tmp_path / "b"), "-q"]) == 0 and (tmp_path / "b_rerun1" / "run.json").exists()


def test_ctrl_c_stops_after_the_current_stage(tmp_path):
    out = tmp_path / "r"
    p = subprocess.Popen([sys.executable, "-m", "ares.cli", "run", str(ROOT / "scans" / "photon_transfer.xml"),
                          "--out", str(out)], stderr=subprocess.PIPE, stdout=subprocess.PIPE, cwd=ROOT,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        for line in p.stderr:
            if line.startswith(b"stage 2 "):
                p.send_signal(signal.SIGINT)
                break
        _, err = p.communicate(timeout=600)
    finally:
        if p.poll() is None:
            p.kill()
    rec = load_run(out)
    if p.returncode == 0:  # the whole scan finished before the signal arrived (very slow machine only)
        pytest.skip("scan finished before SIGINT")
    assert p.returncode == 130, err
    assert rec.meta["status"] == "stopped" and 3 <= len(rec.stages) < 26
    assert b"completed stages are kept" in err


def test_auto_repeat_from_the_cli(tmp_path, ptc_small_no_pdf, capsys):
    PTC = str(ptc_small_no_pdf)
    assert main(["run", PTC, "--out", str(tmp_path / "rep"), "-q", "--frames", "2", "--repeat", "2"]) == 0
    assert [load_run(tmp_path / "rep" / f"repeat_{i:03d}").meta["status"] for i in (1, 2)] == ["done", "done"]


def test_out_dir_resolution(tmp_path, ptc_small_no_pdf, capsys):
    from ares.commands.run import resolve_out

    assert resolve_out(tmp_path / "new", "s") == tmp_path / "new"
    (tmp_path / "empty").mkdir()
    assert resolve_out(tmp_path / "empty", "s") == tmp_path / "empty"
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("x")
    assert resolve_out(tmp_path / "other", "s").parent == tmp_path / "other"
    # `make run` style: the same --out twice never fails and never overwrites
    PTC = str(ptc_small_no_pdf)  # (statuses compared)
    for _ in range(2):
        assert main(["run", PTC, "--out", str(tmp_path / "runs"), "-q", "--frames", "2"]) == 0
    assert load_run(tmp_path / "runs").meta["status"] == load_run(tmp_path / "runs_2").meta["status"] == "done"


def test_progress_bar_on_a_terminal():
    import io

    from ares.commands.run import ProgressBar
    from ares.protocol import load_scan
    from ares.scan import Runner

    class Tty(io.StringIO):
        def isatty(self):
            return True

    s = Tty()
    Runner(load_scan(PTC), frames=2, listeners=(ProgressBar(s),)).run()
    text = s.getvalue()
    assert "\rstage 8 ptc[7]" in text and "  9/9 [" in text and "100%" in text and "frames/s ETA 0:00:00" in text
    assert text.endswith("\n")
