"""Command lines that used to be misread (issue 38, "commands without traps"): a file list
swallowed by --dark, a conversion gain in uV/e- taken as DN/e-, a 2-D scan benchmarked as
if it were a light sweep. Each case failed before the change."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ares.cli import main


def _stacks(tmp_path, n=6, shape=(24, 32), q=3000.0, k=0.5):
    rng = np.random.default_rng(7)
    fpn = rng.normal(0, 3, shape)
    dark = np.round(200 + fpn + rng.normal(0, 2, (n,) + shape)).astype(np.uint16)
    flat = np.round(200 + fpn + rng.normal(0, 2, (n,) + shape)
                    + k * (q + np.sqrt(q) * rng.standard_normal((n,) + shape))).astype(np.uint16)
    d, f = [], []
    for i in range(n):
        d.append(tmp_path / f"d{i}.npy")
        f.append(tmp_path / f"b{i}.npy")
        np.save(d[-1], dark[i])
        np.save(f[-1], flat[i])
    return [str(p) for p in d], [str(p) for p in f]


def test_dark_list_that_took_every_file_is_refused_naming_the_cause(tmp_path, capsys):
    """`ares analyze --dark d*.npy b*.npy`: argparse gave every file to --dark and then
    said "the following arguments are required: files"; now one sentence says what happened."""
    d, f = _stacks(tmp_path)
    assert main(["analyze", "--dark", *d, *f]) == 2
    err = capsys.readouterr().err
    assert f"--dark took all {len(d) + len(f)} file(s)" in err and "--flat" in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_flat_option_and_positional_files_give_the_same_result(tmp_path, capsys):
    d, f = _stacks(tmp_path)
    assert main(["analyze", "--dark", *d, "--flat", *f, "--json"]) == 0
    a = json.loads(capsys.readouterr().out)
    assert main(["analyze", *f, "--dark", *d, "--json"]) == 0
    b = json.loads(capsys.readouterr().out)
    assert a["G"] == b["G"] and a["G"]["value"] == pytest.approx(0.5, abs=0.05)


@pytest.mark.parametrize("spelled", ["0.5", "0.5DN/e-", "2e-/DN", "35uV/e-"])
def test_a_gain_with_its_unit_reaches_the_analysis_in_dn_per_e(tmp_path, capsys, spelled):
    """0.5 DN/e- spelled four ways (35 uV/e- with a 70 uV LSB) gives the same Poisson check."""
    d, f = _stacks(tmp_path)
    assert main(["analyze", *f, "--dark", *d, "--gain", spelled, "--adc-lsb-uv", "70", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["poisson_ratio"]["value"] == pytest.approx(1.0, abs=0.15)


def test_a_conversion_gain_without_the_lsb_is_refused(tmp_path, capsys):
    d, f = _stacks(tmp_path)
    assert main(["analyze", *f, "--dark", *d, "--gain", "70uV/e-"]) == 2
    err = capsys.readouterr().err
    assert "needs the ADC step (--adc-lsb-uv" in err and err.count("\n") == 1


def test_a_bare_conversion_gain_is_refused_by_the_parser(capsys):
    """The user who read "conversion gain 70 uV/e-" from `ares run` and typed --gain 70
    got a Poisson check of 0.004 and exit 0."""
    with pytest.raises(SystemExit) as ei:
        main(["analyze", "x.npy", "--gain", "70"])
    assert ei.value.code == 2
    assert "70uV/e-" in capsys.readouterr().err


def test_analyze_prints_gain_spreads_as_percent_rms_like_ares_run(tmp_path, capsys):
    """`ares analyze` printed relative variances with six digits where `ares run` prints
    % rms with the SE's digits: both now go through report.tables.component_text."""
    d, f = _stacks(tmp_path)
    assert main(["analyze", *f, "--dark", *d]) == 0
    text = capsys.readouterr().out
    pg = [ln for ln in text.splitlines() if ln.split()[:1] == ["Pg"]][0]
    assert "% rms" in pg
    g = [ln for ln in text.splitlines() if ln.split()[:1] == ["G"]][0].split()
    # two significant digits of the SE, the value to the same place
    se = g[3]
    assert len(se.replace("0.", "").lstrip("0")) == 2 and len(g[1].split(".")[-1]) == len(se.split(".")[-1])


ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def test_bench_refuses_a_2d_sweep_before_running_anything(tmp_path, capsys):
    """`ares bench scans/gain.xml --quick` ran the gain x light sweep as one curve and
    reported 87 % "errors"; now it refuses in one sentence and writes nothing."""
    out = tmp_path / "b"
    assert main(["bench", str(ROOT / "scans" / "gain.xml"), "--quick", "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "sweeps analog_gain x light (a 2-D sweep)" in err and err.count("\n") == 1
    assert not out.exists()


def test_bench_grid_defaults_to_the_scans_own_sensor():
    import argparse

    from ares.commands.bench import _grid
    from ares.protocol import load_scan
    from ares.tuning import grid

    scan = load_scan(ROOT / "scans" / "photon_transfer.xml")
    ns = argparse.Namespace(quick=False, frames=None, levels=None, spacing=None, size=None, fidelity=None)
    g = _grid(ns, scan)
    assert g["size"] == ((scan.system.sensor.rows, scan.system.sensor.cols),)
    s = grid.settings(g)[0]
    cut = grid.scan_for(scan, s)
    assert (cut.system.sensor.rows, cut.system.sensor.cols) == (480, 640)
    assert s.label().startswith("640x480 ")
    ns.quick = True
    assert _grid(ns, scan)["size"] == (64,)


def test_resume_summary_counts_the_stages_it_ran(tmp_path, capsys, ptc_small_no_pdf):
    """The resume summary said "26 stage(s) in 4.7 s" when 16 ran: the time is this
    session's and is now charged to the stages run now."""
    import json as _json

    d = tmp_path / "run"
    scan = ptc_small_no_pdf  # (stage counts and the summary: no PDF read)
    # late enough that a flat has completed the defect mask: the stages before the first one
    # still on the provisional (dark-only) mask are the ones resume keeps (ares.scan.resume)
    assert main(["run", str(scan), "--out", str(d), "--quiet", "--sim-fault", "disconnect_after_frames=30"]) == 3
    on_disk = [_json.loads(p.read_text()) for p in sorted((d / "stages").glob("[0-9][0-9][0-9][0-9].json"))]
    kept = next((k for k, st in enumerate(on_disk) if (st.get("defect_mask") or {}).get("provisional")), len(on_disk))
    capsys.readouterr()
    assert main(["resume", str(d), "--quiet"]) == 0
    total = len(list((d / "stages").glob("[0-9][0-9][0-9][0-9].json")))
    out = capsys.readouterr().out
    assert 0 < kept < total and _json.loads((d / "run.json").read_text())["status"] == "done"
    assert f"{total} stage(s): {total - kept} run now in " in out and f"after {kept} resumed" in out
