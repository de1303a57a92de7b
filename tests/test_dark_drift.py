"""A black level drifting on the bench's clock (``ares.sim.drift``) against the dark current
(``ares.analysis.ptc.dark_drift``), checked against the simulator's truth: a die warm-up of
3 DN with a 100 s time constant during a dark sweep of 8 exposures x 16 frames (~65 s of clock)
adds ~1 DN/s to a ~2.5 DN/s dark current taken in increasing order -- "ok" at many SE before;
now the drift is fitted beside the rate on every frame's mean and readout time: not "ok" in
increasing order (the order cannot separate them, with what to do), right within 3 SE in
shuffled order; without a drift, the same figures as before."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ares.analysis.ptc.dark_current import dark_current
from ares.errors import InputError
from ares.protocol import load_scan
from ares.analysis.stats.estimate import format_dict
from ares.results.dark_drift import frame_times, inherit
from ares.rig.factory import build_bench
from ares.scan import Runner
from ares.sim import SensorParams, make_sim_bench
from ares.sim.drift import offset_dn, rate_dn_per_s

ROOT = Path(__file__).resolve().parents[1]
WARMUP = {"offset_warmup_dn": 3.0, "offset_warmup_tau_s": 100.0}
INCREASING = '<axis quantity="exposure"><linear start="0.01" stop="1.0" points="8"/></axis>'  # (the shipped scan's)
TEMPERATURE_KEYS = ("doubling_temperature_c", "rate_at_ref_dn_per_s", "rate_at_ref_e_per_s")
SHUFFLED = INCREASING.replace('quantity="exposure"', 'quantity="exposure" order="shuffled"')


def test_the_black_level_drifts_at_each_frames_readout_as_its_truth_says():
    """Frame means of the drifting sensor minus the same seed's steady one: the truth's offset at
    each frame's readout (its exposure's end), the noise unchanged; a warm-up's rate its derivative."""
    p = SensorParams(rows=16, cols=24).without_defects()
    frames = []
    for q in (p.replace(**WARMUP, offset_drift_dn_per_s=0.01), p):
        b = make_sim_bench(q, 3)
        b.registers.set("exposure", 2.0)
        b.registers.set("test_mode", 1)
        frames.append(list(b.frames.grab(6)))
    sensor = make_sim_bench(p.replace(**WARMUP, offset_drift_dn_per_s=0.01), 3).info["sensor"]
    d = np.array([a.data.mean() - b.data.mean() for a, b in zip(*frames)])
    want = np.array([sensor.offset_drift_dn(f.timestamp + 2.0) for f in frames[0]])
    assert np.abs(d - want).max() < 0.05 and want[-1] > 0.3
    q = p.replace(**WARMUP)
    assert rate_dn_per_s(q, 10.0) == pytest.approx((offset_dn(q, 10.001) - offset_dn(q, 9.999)) / 0.002, rel=1e-5)
    assert offset_dn(p, 50.0) == 0.0
    with pytest.raises(InputError, match="offset_warmup_tau_s"):
        p.replace(offset_warmup_tau_s=0.0)


def _system(tmp: Path, params: dict) -> Path:
    text = (ROOT / "protocols" / "sim_sensor.xml").read_text()
    for k, v in (("rows", 32), ("cols", 48)):
        text = text.replace(f'name="{k}" type="int" value="{480 if k == "rows" else 640}"',
                            f'name="{k}" type="int" value="{v}"')
    text = text.replace('rows="480" cols="640"', 'rows="32" cols="48"')
    text = text.replace("</simulator>", "".join(f'<param name="{k}" type="float" value="{v}"/>'
                                                for k, v in params.items()) + "</simulator>")
    p = tmp / "sim_drift.xml"
    p.write_text(text)
    return p


def _sweep(tmp: Path, params: dict, axis: str, seed: int = 1) -> tuple:
    """A dark sweep at 40 C on the 32x48 simulator: (the dark_current results, its stages, the truth
    DN/s: G x the mean pixel dark current, hot pixels included as the mean measures them)."""
    scan = tmp / "dark_drift.xml"
    scan.write_text(f"""<?xml version="1.0"?>
<scan name="dark_drift" version="1">
  <system href="{_system(tmp, params)}"/>
  <settings><set quantity="temperature" value="40"/><set quantity="analog_gain" value="1"/></settings>
  <frames>16</frames>
  <stages><sweep name="dark" scene="dark">
    {axis}</sweep></stages>
  <analyses><analysis name="dark_current"/></analyses>
  <output pdf="false" csv="false" hdf5="false"/>
</scan>
""")
    s = load_scan(scan)
    bench = build_bench(s.system, seed=seed)
    out = Runner(s, bench=bench).run()
    assert out.status == "done", out.message
    t = bench.info["sensor"].truth(exposure_s=1.0, temperature_c=40.0)
    return out.scan_results["dark_current"], out.stages, t["G"] * float(t["maps"]["dark_e_per_s"].mean())


def _without_times(stages) -> object:
    """The fit as it was before the frames' times were used (the levels and their frames' scatter)."""
    lv = [s["views"]["full"]["level"] for s in stages]
    return dark_current([s["settings"]["exposure"] for s in stages], [x["mean_dn"] for x in lv], math.nan,
                        frame_means=[x["frame_means"] for x in lv]).rate_dn_per_s


def test_a_warming_offset_in_increasing_order_is_not_ok_and_says_why(tmp_path):
    res, stages, truth = _sweep(tmp_path, WARMUP, INCREASING)
    before = _without_times(stages)
    assert before.verdict == "ok" and (before.value - truth) / before.se > 5  # the wrong "ok" it was
    r = res["rate_dn_per_s"]
    assert r["verdict"] == "drift not separated" and "shuffled order" in r["drift"] and "reference darks" in r["drift"]
    assert format_dict(r).endswith("not ok: drift not separated")  # (as the terminal and the window show it)
    t = inherit({k: {"value": 1.0, "se": 0.1, "verdict": "ok"} for k in TEMPERATURE_KEYS}, [(40.0, r), (60.0, {})])
    assert all(v["verdict"] == "drift not separated" and "40 C" in v["drift"] for v in t.values())
    assert res["offset_drift_dn_per_s"]["value"] > 3 * res["offset_drift_dn_per_s"]["se"]


def test_a_warming_offset_in_shuffled_order_gives_the_dark_current_within_3_se(tmp_path):
    res, stages, truth = _sweep(tmp_path, WARMUP, SHUFFLED)
    r = res["rate_dn_per_s"]
    assert r["verdict"] == "ok" and abs(r["value"] - truth) <= 3 * r["se"], (r, truth)
    assert "drift fitted on every frame" in r["note"]
    assert [s["settings"]["exposure"] for s in stages] != sorted(s["settings"]["exposure"] for s in stages)
    times = [frame_times(s) for s in stages]  # the frames' readout times span the sweep on the bench's clock
    assert all(np.all(np.diff(t) > 0) for t in times) and max(max(t) for t in times) > 60


def test_a_warming_offset_bracketed_by_reference_darks_gives_the_dark_current_within_3_se(tmp_path):
    """The other remedy the verdict names: the increasing sweep with a reference dark at 0.01 s
    before and after it -- the references measure the drift across the sweep (its curvature: the
    warm-up's parabola is kept), the rate is "ok" and right."""
    axis = '<axis quantity="exposure"><values>0.01 ' + " ".join(f"{x:.6g}" for x in np.linspace(0.01, 1.0, 8)) + \
        " 0.01</values></axis>"
    res, stages, truth = _sweep(tmp_path, WARMUP, axis)
    r = res["rate_dn_per_s"]
    assert r["verdict"] == "ok" and abs(r["value"] - truth) <= 3 * r["se"], (r, truth)
    assert "parabola" in r["note"]


def test_through_the_wires_the_devices_time_stamps_time_the_frames(tmp_path):
    """A real bench's path: the simulator behind the emulated USB grabber with ares40 headers (the
    device's time stamp at each exposure's start), no clock position in the stage JSON -- the frames'
    times from results.h5; shuffled, the warm-up's dark current within 3 SE of its truth."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from wire_small import small_wire

    system = small_wire(tmp_path)
    text = system.read_text()
    assert 'header="ares32"' in text
    system.write_text(text.replace('header="ares32"', 'header="ares40"').replace("</simulator>", "".join(
        f'<param name="{k}" type="float" value="{v}"/>' for k, v in WARMUP.items()) + "</simulator>"))
    scan = tmp_path / "wire_drift.xml"
    scan.write_text(f"""<?xml version="1.0"?>
<scan name="wire_drift" version="1"><system href="{system}"/><frames>8</frames>
<stages><sweep name="dark" scene="dark">{SHUFFLED}</sweep></stages>
<analyses><analysis name="dark_current"/></analyses><output pdf="false" csv="false" hdf5="true"/></scan>""")
    s = load_scan(scan)
    bench = build_bench(s.system, seed=1)
    out = Runner(s, bench=bench, out_dir=tmp_path / "run").run()
    assert out.status == "done" and "bench_position" not in out.stages[0]
    t = bench.info["sensor"].truth(exposure_s=1.0, temperature_c=25.0)  # (the chamber's default: none set)
    truth = t["G"] * float(t["maps"]["dark_e_per_s"].mean())
    r = out.scan_results["dark_current"]["rate_dn_per_s"]
    assert r["verdict"] == "ok" and "drift fitted on every frame" in r["note"] and abs(r["value"] - truth) <= 3 * r["se"]


def test_without_a_drift_the_value_is_unchanged_and_the_se_holds_the_drift_it_cannot_exclude(tmp_path):
    """No drift: the rate is the one fitted without the frames' times; in increasing order its SE
    holds the drift the frames cannot exclude (its SE x the clock seconds per second of exposure)."""
    res, stages, truth = _sweep(tmp_path, {}, INCREASING)
    r, before = res["rate_dn_per_s"], _without_times(stages)
    d = dark_current([s["settings"]["exposure"] for s in stages], [s["views"]["full"]["level"]["mean_dn"] for s in stages],
                     math.nan, frame_means=[s["views"]["full"]["level"]["frame_means"] for s in stages],
                     frame_times=[frame_times(s) for s in stages]).drift
    assert r["verdict"] == "ok" and r["value"] == before.value and not d.kept and d.follows_clock > 0.8
    assert r["se"] == pytest.approx(math.hypot(before.se, d.drift_se * d.shift_per_drift), rel=1e-12)
    assert r["se"] > 2 * before.se  # (here the drift's term dominates)
    assert "the frames show no drift" in r["note"] and "the SE holds" in r["note"] and abs(r["value"] - truth) <= 3 * r["se"]


def test_a_drift_below_the_frames_detection_limit_in_increasing_order_is_no_wrong_ok():
    """A linear drift of 0.005 DN/s (below what 16 frames a stack can show: ~0.008 DN/s) in increasing
    order moved the rate ~6 SE unseen -- a wrong "ok" on 3 of 4 sweeps. The SE now holds the drift the
    frames cannot exclude: 3 SE cover the truth on >= 97 % of 200 synthetic sweeps."""
    rng = np.random.default_rng(60)
    miss, n = 0, 200
    for _ in range(n):
        t, m, fm, ft = _warming_sweep(rng, np.arange(8), a_dn=0.0, lin=0.005)
        r = dark_current(t, m, 0.28, frame_means=fm, frame_times=ft)
        e = r.rate_dn_per_s
        miss += e.available and r.drift.separable and abs(e.value - 2.5) > 3 * e.se
    assert miss <= 0.03 * n, miss


def test_a_shuffled_axis_is_a_fixed_order_no_drift_follows_and_is_saved_as_written(tmp_path):
    """``<axis order="shuffled" seed>``: the same points in a seeded order whose ranks correlate
    least with their position (straight and curved); it survives save and reload; a seed without
    it is named with its file and line."""
    from ares.protocol.scan import Axis
    from ares.protocol.scan_write import save_scan

    g = np.array(Axis("exposure", "linear", (), 0.01, 1.0, 8, "shuffled", 3).grid())
    assert sorted(g) == pytest.approx(np.linspace(0.01, 1.0, 8))
    pos = np.arange(8.0)
    assert abs(np.corrcoef(g, pos)[0, 1]) < 0.2 and abs(np.corrcoef(g, (pos - 3.5) ** 2)[0, 1]) < 0.2
    assert tuple(g) == Axis("exposure", "linear", (), 0.01, 1.0, 8, "shuffled", 3).grid()  # (fixed)
    path = tmp_path / "s.xml"
    path.write_text(f"""<?xml version="1.0"?>
<scan name="s" version="1"><system href="{ROOT / 'protocols' / 'sim_sensor.xml'}"/><frames>4</frames>
<stages><sweep name="dark" scene="dark">
<axis quantity="exposure" order="shuffled" seed="3"><linear start="0.01" stop="1.0" points="8"/></axis>
</sweep></stages></scan>""")
    sc = load_scan(path)
    assert sc.stages[0].axes[0].grid() == tuple(g)
    save_scan(sc, tmp_path / "again.xml")
    assert load_scan(tmp_path / "again.xml").stages[0].axes[0] == sc.stages[0].axes[0]
    path.write_text(path.read_text().replace('order="shuffled" ', ""))
    with pytest.raises(InputError, match=r"s\.xml:4: .*seed= orders the points only with order=\"shuffled\""):
        load_scan(path)
    path.write_text(path.read_text().replace('seed="3"', 'order="random"'))
    with pytest.raises(InputError, match=r"s\.xml:4: .*order"):
        load_scan(path)


def _warming_sweep(rng, order, a_dn=3.0, tau_s=100.0, rate=2.5, fg=0.2, frames=16, lin=0.0):
    """Frame means and readout times of a dark sweep (exposures 0.01 - 1 s in ``order``) on a bench
    whose offset warms up by ``a_dn`` with ``tau_s`` from clock 0 (and drifts by ``lin`` DN/s),
    frames one exposure apart."""
    t = np.linspace(0.01, 1.0, 8)[order]
    clock, fm, ft = 5.0, [], []
    for e in t:
        ts = clock + e * np.arange(1, frames + 1)
        clock = ts[-1]
        fm.append(64 + rate * e + a_dn * -np.expm1(-ts / tau_s) + lin * ts + rng.normal(0, fg, frames))
        ft.append(ts)
    return t, [float(f.mean()) for f in fm], fm, ft


def test_over_many_sweeps_shuffled_covers_the_truth_and_increasing_is_never_ok():
    """100 synthetic sweeps each (frame-global noise 0.2 DN, 16 frames): shuffled, 3 SE cover the
    truth on >= 97 %; increasing, the drift is seen and the rate never "ok"-separable."""
    from ares.protocol.scan import shuffled_order

    rng = np.random.default_rng(59)
    shuffled = shuffled_order(np.arange(8), 1)
    miss = seen = 0
    n = 100
    for _ in range(n):
        t, m, fm, ft = _warming_sweep(rng, shuffled)
        r = dark_current(t, m, 0.28, frame_means=fm, frame_times=ft)
        miss += abs(r.rate_dn_per_s.value - 2.5) > 3 * r.rate_dn_per_s.se or not r.drift.separable
        t, m, fm, ft = _warming_sweep(rng, np.arange(8))
        d = dark_current(t, m, 0.28, frame_means=fm, frame_times=ft).drift
        seen += d.kept and not d.separable
    assert miss <= 0.03 * n and seen == n


def test_a_real_benchs_frame_times_come_from_its_time_stamps():
    """Without the simulator's clock position: the device's time stamps (exposure start) + the
    exposure, else the host's arrival times; neither: no times (the drift is not fitted)."""

    class Run:
        def __init__(self, arrays):
            self.a = arrays

        def arrays(self, index, names=None):
            return {k: v for k, v in self.a.items() if names is None or k in names}

    st = {"index": 3, "settings": {"exposure": 0.5}, "views": {"full": {"level": {"frame_means": [1.0, 2.0, 3.0]}}}}
    host, dev = np.array([10.0, 10.6, 11.2]), np.array([100.0, 100.5, 101.0])
    assert frame_times(st, Run({"frame_timestamp": host, "frame_device_timestamp": dev})) == [100.5, 101.0, 101.5]
    assert frame_times(st, Run({"frame_timestamp": host})) == list(host)
    assert frame_times(st, Run({})) is None and frame_times(st) is None
    st["bench_position"] = {"flat": {"clock_s": 4.0}, "end": {"clock_s": 5.5}}  # the simulator's: its clock
    assert frame_times(st, Run({"frame_timestamp": host})) == [4.5, 5.0, 5.5]


@pytest.mark.study
@pytest.mark.parametrize("order", ["increasing", "shuffled", "bracketed"])
def test_study_a_warm_up_over_seeds_against_truth(tmp_path, order):
    """20 simulator seeds of the 3 DN warm-up (benchmarks/dark_drift.md has 40, and more drifts):
    increasing order is never "ok"; shuffled or bracketed by reference darks, "ok" within 3 SE on
    >= 18 of 20."""
    axis = {"increasing": INCREASING, "shuffled": SHUFFLED,
            "bracketed": '<axis quantity="exposure"><values>0.01 ' + " ".join(f"{x:.6g}" for x in np.linspace(0.01, 1.0, 8))
                         + " 0.01</values></axis>"}[order]
    good = 0
    for seed in range(1, 21):
        res, _, truth = _sweep(tmp_path, WARMUP, axis, seed)
        r = res["rate_dn_per_s"]
        if order == "increasing":
            assert r["verdict"] == "drift not separated", (seed, r)
        good += r["verdict"] == "ok" and abs(r["value"] - truth) <= 3 * r["se"]
    assert order == "increasing" or good >= 18
