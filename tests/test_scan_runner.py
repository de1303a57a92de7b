"""Scan runner: stage expansion, events, pause/stop/abort, hardware faults, repeatability."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest

from ares.errors import DeviceGone, FrameError, HardwareError
from ares.protocol import load_scan
from ares.scan import Runner, auto_repeat, events as ev, expand, load_run

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small"


@pytest.fixture(scope="module")
def ptc_small():
    return load_scan(SMALL / "ptc_small.xml")


def _timed(scan):
    """``scan`` on its system with the declared waits only (``<settle by="time">``)."""
    import dataclasses

    from ares.protocol.settle import Settle

    t = dataclasses.replace(scan.system.timing, settle=Settle(by="time"))
    return dataclasses.replace(scan, system=dataclasses.replace(scan.system, timing=t))


def _no_pdf(scan):
    """``scan`` without its PDF: for runs whose checks read results, stages and files, not the
    report (the PDF was most of a small run's time; the report's own tests read it)."""
    import dataclasses

    return dataclasses.replace(scan, output=dataclasses.replace(scan.output, pdf=False))


@pytest.fixture(scope="module")
def bias_small():
    return load_scan(SMALL / "bias_small.xml")


def test_expand_light_sweep_reuses_one_dark():
    st = expand(load_scan(ROOT / "scans" / "photon_transfer.xml"))
    assert len(st) == 26 and st[0].scene == "dark" and st[0].settings["light"] == 0
    assert all(s.dark_source == "reuse" for s in st[1:])  # the 32-frame dark stage serves every level
    lights = [s.settings["light"] for s in st[1:]]
    assert lights == sorted(lights) and lights[0] == pytest.approx(1e3) and lights[-1] == pytest.approx(1e7)
    assert list(st[0].settings)[-1] == "light"  # light is applied last


def test_expand_exposure_sweep_grabs_dark_per_exposure():
    st = expand(load_scan(ROOT / "scans" / "ptc_exposure.xml"))
    assert len(st) == 12 and all(s.dark_source == "grab" for s in st)


def test_expand_2d_sweep_outer_axis_first():
    st = expand(load_scan(ROOT / "scans" / "bias_sweep_2d.xml"))
    assert len(st) == 20
    assert [s.coords for s in st[:5]] == [(0, 0), (0, 1), (0, 2), (0, 3), (1, 0)]
    assert st[0].name == "bias_map[0,0]" and st[0].settings["reg:sf_bias"] == pytest.approx(1.0)
    assert st[-1].settings["reg:tx_low"] == pytest.approx(-0.2)
    assert st[1].dark_source == "grab"  # settings differ: a new matched dark


def test_expand_stage_settings_override_and_frames_override():
    sc = load_scan(ROOT / "scans" / "adc_linearity.xml")
    st = expand(sc)
    assert st[0].settings["reg:test_mode"] == 2 and st[1].settings["reg:test_mode"] == 0
    assert st[0].frames == 16 and st[1].frames == 8
    assert {s.frames for s in expand(sc, frames=3)} == {3}


@pytest.mark.parametrize("name", ["dark_current", "temperature", "gain", "lag", "adc_linearity", "bias_sweep_2d",
                                  "ptc_exposure"])
def test_shipped_scans_run_on_the_simulator(name):
    sc = load_scan(ROOT / "scans" / f"{name}.xml")
    out = Runner(sc, frames=2).run()
    assert out.status == "done" and len(out.stages) == len(expand(sc))


def test_events_in_order(ptc_small):
    seen = []
    out = Runner(ptc_small, listeners=(seen.append,)).run()
    kinds = [type(e).__name__ for e in seen]
    assert kinds[0] == "RunStarted" and kinds[-1] == "Done"
    assert kinds.count("StageStarted") == kinds.count("StageFinished") == 9
    prog = [e for e in seen if isinstance(e, ev.Progress)]
    assert prog[-1].frames_done == prog[-1].frames_total == seen[0].total_frames
    assert all(p.remaining_s is None or p.remaining_s >= 0 for p in prog)
    previews = [e for e in seen if isinstance(e, ev.FramePreview)]
    assert previews[0].data.shape == (24, 32)
    assert out.stages[1]["views"]["full"]["level"]["mean_dn"] > out.stages[0]["views"]["full"]["level"]["mean_dn"]
    # views: full, the scan's region, both ADC channels of the ping-pong readout
    assert set(out.stages[0]["views"]) == {"full", "centre", "adc0", "adc1"}


def test_stop_finishes_the_current_stage(ptc_small, tmp_path):
    r = Runner(_no_pdf(ptc_small), out_dir=tmp_path / "run")

    def listener(e):
        if isinstance(e, ev.FramePreview) and e.index == 2 and e.frame == 1 and not e.dark:
            r.stop()

    r.add_listener(listener)
    out = r.run()
    assert out.status == "stopped" and len(out.stages) == 3
    rec = load_run(tmp_path / "run")
    assert rec.meta["status"] == "stopped" and len(rec.stages) == 3
    assert rec.stages[2]["frames"] == 4  # the stage in flight was completed


def test_abort_drops_only_the_stage_in_flight(ptc_small, tmp_path):
    r = Runner(_no_pdf(ptc_small), out_dir=tmp_path / "run")

    def listener(e):
        if isinstance(e, ev.FramePreview) and e.index == 3 and e.frame == 2:
            r.abort()

    r.add_listener(listener)
    done = []
    r.add_listener(lambda e: isinstance(e, ev.Done) and done.append(e))
    out = r.run()
    assert out.status == "aborted" and len(out.stages) == 3 and done[0].stages_completed == 3
    rec = load_run(tmp_path / "run")
    assert rec.meta["status"] == "aborted" and [s["index"] for s in rec.stages] == [0, 1, 2]
    frames = sorted(p.name for p in (tmp_path / "run" / "frames").iterdir())
    assert frames == ["0000.h5", "0001.h5", "0002.h5"]  # no partial file of the aborted stage


def test_pause_holds_frames_until_resume(ptc_small):
    r = Runner(ptc_small)
    log = []
    resumer = []

    def listener(e):
        log.append(e)
        if isinstance(e, ev.FramePreview) and e.index == 1 and e.frame == 0 and not e.dark:
            r.pause()
        if isinstance(e, ev.Paused):
            def later():
                log.append("resume")  # nothing arrives while paused: resume is the next entry
                r.resume()
            t = threading.Thread(target=later)
            resumer.append(t)
            t.start()

    r.add_listener(listener)
    out = r.run()
    resumer[0].join()
    assert out.status == "done" and len(out.stages) == 9
    # the stage acquired before may finish its analysis meanwhile (ares.scan.commit): no frame does
    log = [e for e in log if not isinstance(e, ev.StageFinished)]
    i = next(k for k, e in enumerate(log) if isinstance(e, ev.Paused))
    assert log[i + 1] == "resume" and isinstance(log[i + 2], ev.Resumed)
    assert isinstance(log[i - 1], ev.Progress) and log[i - 1].index == 1


def test_abort_while_paused(ptc_small):
    r = Runner(ptc_small)

    def listener(e):
        if isinstance(e, ev.FramePreview) and e.index == 2 and e.frame == 0:
            r.pause()
        if isinstance(e, ev.Paused):
            threading.Thread(target=r.abort).start()

    r.add_listener(listener)
    assert r.run().status == "aborted"


@pytest.mark.parametrize("fault,exc,words", [
    ({"disconnect_after_frames": 30}, DeviceGone, "disconnected"),
    ({"short_frame_at": 30}, FrameError, "short"),
])
def test_hardware_fault_keeps_completed_stages(ptc_small, tmp_path, fault, exc, words):
    seen = []
    ptc_small = _timed(ptc_small)  # the faults are placed by frame count: no probe frames
    r = Runner(ptc_small, out_dir=tmp_path / "run", faults=fault, listeners=(seen.append,))
    with pytest.raises(HardwareError) as info:
        r.run()
    assert isinstance(info.value, exc)
    msg = str(info.value)
    assert words in msg and "completed stage(s) saved in" in msg and "\n" not in msg
    rec = load_run(tmp_path / "run")
    # stage 0 = 4 dark frames; each level = 4 dark + 4 flat (dark not reused: the dark stage has
    # the same settings and frame count, so it is) -> 4 frames per level: 30 frames = 6 full stages + 2
    assert rec.meta["status"] == "failed" and words in rec.meta["message"]
    assert len(rec.stages) == 7 == seen[-1].stages_completed
    assert isinstance(seen[-1], ev.Failed)


def test_same_seed_same_results_and_other_seed_differs(ptc_small):
    a = Runner(ptc_small, seed=3).run()
    b = Runner(ptc_small, seed=3).run()
    c = Runner(ptc_small, seed=4).run()
    strip = lambda st: json.dumps([{k: v for k, v in s.items() if k != "timing"} for s in st], sort_keys=True)
    assert strip(a.stages) == strip(b.stages)
    assert strip(a.stages) != strip(c.stages)


def test_frames_not_kept_unless_asked(bias_small, tmp_path):
    out = Runner(_no_pdf(bias_small), out_dir=tmp_path / "run").run()
    assert out.status == "done" and not (tmp_path / "run" / "frames").exists()
    assert len(out.stages) == 6 and out.limit_failures  # the fixture's Pt limit fails on purpose


def test_auto_repeat(ptc_small, tmp_path):
    import dataclasses

    scan = dataclasses.replace(ptc_small, output=dataclasses.replace(ptc_small.output, pdf=False))  # (statuses only)
    outs = auto_repeat(lambda i: Runner(scan, out_dir=tmp_path / f"r{i}", frames=2), count=2)
    assert [o.status for o in outs] == ["done", "done"] and (tmp_path / "r1" / "run.json").exists()


def test_runner_refuses_mismatched_frame_source(ptc_small):
    from ares.rig.factory import build_bench
    from ares.protocol import load_system

    bench = build_bench(load_system(ROOT / "protocols" / "sim_sensor.xml"))
    with pytest.raises(Exception, match="declares a 32x24 array"):
        Runner(ptc_small, bench=bench).run()


def test_photon_transfer_recovers_the_simulators_truth(tmp_path):
    """The main job, end to end on the shipped files: K, conversion gain and the gain part."""
    from ares.sim.from_system import sim_params

    sc = load_scan(ROOT / "scans" / "photon_transfer.xml")
    out = Runner(_no_pdf(sc), out_dir=tmp_path / "pt").run()
    assert out.status == "done" and not out.limit_failures
    p = sim_params(sc.system)
    k_true = p.gain_dn_per_e(1.0)
    ptc = out.scan_results["ptc"]
    assert abs(ptc["gain_dn_per_e"]["value"] - k_true) < 0.03 * k_true
    assert abs(ptc["conversion_gain_uv_per_e"]["value"] - p.conversion_gain_uv_per_e) < 0.03 * p.conversion_gain_uv_per_e
    comps = out.scan_results["decomposition"]["components"]
    assert {"o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "G", "Cg", "Rg", "Pg", "q", "delta"} <= set(comps)
    assert abs(comps["G"]["value"] - k_true) < 0.03 * k_true
    assert out.scan_results["defects"]["counts"]["total"] >= 0


def test_unknown_defect_threshold_is_refused_before_hardware(tmp_path):
    import dataclasses

    from ares.errors import InputError

    sc = dataclasses.replace(load_scan(SMALL / "ptc_small.xml"), defects=(("hot_dn", 3.0),))
    with pytest.raises(InputError, match="unknown defect parameter 'hot_dn'"):
        Runner(sc, out_dir=tmp_path / "x")
    assert not (tmp_path / "x").exists()


def test_dark_current_temperature_and_lag_analyses():
    dc = Runner(load_scan(ROOT / "scans" / "dark_current.xml"), frames=4).run().scan_results["dark_current"]
    assert dc["gain_from"] == "ptc in this run" and dc["rate_e_per_s"]["value"] > 0
    import dataclasses

    sc = load_scan(ROOT / "scans" / "lag.xml")  # at 20x the shipped lag: the ordering well above the SE
    sim = dataclasses.replace(sc.system.simulator, params={**sc.system.simulator.params, "lag_fraction": 0.002})
    sc = dataclasses.replace(sc, system=dataclasses.replace(sc.system, simulator=sim))
    lag = Runner(sc).run().scan_results["lag"]["cycles"]
    # more negative transfer-gate low level -> more lag (the simulator's bias model)
    assert lag["bright_a"]["lag_pct"]["value"] < lag["bright_b"]["lag_pct"]["value"] < lag["bright_c"]["lag_pct"]["value"]


def test_adc_linearity_from_the_ramp_stage(tmp_path):
    from ares.sim.from_system import sim_params

    sc = load_scan(ROOT / "scans" / "adc_linearity.xml")
    res = Runner(_no_pdf(sc), out_dir=tmp_path / "adc", frames=4).run().scan_results["adc_linearity"]
    ch = res["channels"]["full"]
    inl = sim_params(sc.system).adc_inl_lsb  # half-sine bow of this amplitude
    assert res["stages"] == ["ramp"] and ch["missing_codes"] == 0
    assert 0.5 * inl < max(ch["inl_max_lsb"]["value"], -ch["inl_min_lsb"]["value"]) < 2 * inl


def test_bayer_views(tmp_path):
    import dataclasses

    sc = load_scan(SMALL / "ptc_small.xml")
    sy = dataclasses.replace(sc.system, sensor=dataclasses.replace(sc.system.sensor, cfa="GRBG", adc_channels=1,
                                                                     adc_interleave="none"))
    sc = dataclasses.replace(sc, system=sy)
    out = Runner(sc, frames=2).run()
    views = out.stages[3]["views"]
    assert set(views) == {"full", "centre", "cfa_Gr", "cfa_R", "cfa_B", "cfa_Gb"}
    assert views["cfa_R"]["level"]["n_pixels"] == 12 * 16


def test_keyboard_interrupt_without_handler_aborts_and_keeps_stages(ptc_small, tmp_path):
    r = Runner(_no_pdf(ptc_small), out_dir=tmp_path / "run")

    def listener(e):
        if isinstance(e, ev.FramePreview) and e.index == 2:
            raise KeyboardInterrupt

    r.add_listener(listener)
    out = r.run()
    assert out.status == "aborted" and len(out.stages) == 2
    assert load_run(tmp_path / "run").meta["status"] == "aborted"


def test_listener_bug_is_recorded_and_reraised(ptc_small, tmp_path):
    seen = []

    def listener(e):
        seen.append(e)
        if isinstance(e, ev.StageFinished) and e.index == 1:
            raise ZeroDivisionError("oops")

    with pytest.raises(ZeroDivisionError):
        Runner(ptc_small, out_dir=tmp_path / "run", listeners=(listener,)).run()
    meta = load_run(tmp_path / "run").meta
    assert meta["status"] == "failed" and "ZeroDivisionError: oops" in meta["message"]
    assert isinstance(seen[-1], ev.Failed) and meta["stages_completed"] == 2


def test_frame_timeout_from_any_backend(ptc_small, tmp_path):
    """A FrameSource that times out (as the USB grabber does) ends the run like the sim faults."""
    from ares.rig.factory import build_bench

    ptc_small = _timed(ptc_small)  # the fault is placed by frame count: no probe frames
    bench = build_bench(ptc_small.system)
    real = bench.frames

    class Slow:
        name, shape, bit_depth = "usb grabber", real.shape, real.bit_depth
        n = 0

        def grab(self, k):
            for f in real.grab(k):
                Slow.n += 1
                if Slow.n > 10:
                    raise HardwareError("usb grabber: no frame within 1000 ms (timeout)")
                yield f

    bench.frames = Slow()
    with pytest.raises(HardwareError, match=r"timeout\) \(during stage 2, 3 of 9; 2 completed stage\(s\) saved"):
        Runner(ptc_small, bench=bench, out_dir=tmp_path / "t").run()
    assert len(load_run(tmp_path / "t").stages) == 2
