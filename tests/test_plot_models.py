"""Plot models of the GUI, without Qt: hand-computed numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ares.errors import InputError, Interrupted
from ares.gui import events as E
from ares.gui.engine import DemoScan
from ares.gui.models import progress as P
from ares.gui.models.defects import DefectCountsModel
from ares.gui.models.profiles import region_profiles
from ares.gui.models.ptc import PTCModel
from ares.gui.models.regions import Region, RegionSet, load_roa, save_roa
from ares.gui.models.session import SessionModel
from ares.gui.models.stats import (MANUAL, MEAN_3_SIGMA, PEAK_TO_PEAK, PERCENTILE, StatsPanelModel, auto_range,
                                   bins_for, histogram)


# ---- stats panels -------------------------------------------------------------------------
def test_stats_hand_computed():
    m = StatsPanelModel("MEAN SIGNAL")
    m.set_values(np.array([1.0, 2.0, 3.0, 4.0, 5.0]))
    s = m.stats
    assert (s.n, s.mean, s.lowest, s.highest) == (5, 3.0, 1.0, 5.0)
    assert s.sigma == pytest.approx(math.sqrt(2.5))  # ddof=1
    assert m.range == pytest.approx((0.4, 5.6))  # 15 % of the 4-DN span each side
    assert m.counts.sum() == 5


def test_peak_to_peak_margin_matches_ares_screenshot():
    # MEAN SIGNAL panel: Lowest 32.20, Highest 37.80 -> From 31.36, To 38.64
    assert auto_range(np.array([32.20, 34.0, 37.80]), PEAK_TO_PEAK) == pytest.approx((31.36, 38.64))
    # NOISE panel: Lowest 0.00, Highest 3.05 -> From -0.46, To 3.51
    frm, to = auto_range(np.array([0.0, 1.0, 3.05]), PEAK_TO_PEAK)
    assert (round(frm, 2), round(to, 2)) == (-0.46, 3.51)


def test_mean_3_sigma_range():
    frm, to = auto_range(np.array([1.0, 2, 3, 4, 5]), MEAN_3_SIGMA)
    assert (frm, to) == pytest.approx((3 - 3 * math.sqrt(2.5), 3 + 3 * math.sqrt(2.5)))


def test_manual_range_excludes_outlier_and_restore():
    m = StatsPanelModel("NOISE")
    m.set_values(np.array([1.0, 2.0, 3.0, 100.0]))
    m.set_range(0.0, 10.0)
    assert m.range_mode == MANUAL
    assert (m.stats.n, m.stats.mean, m.stats.highest) == (3, 2.0, 3.0)
    m.restore()
    assert m.range_mode == PEAK_TO_PEAK and m.stats.n == 4 and m.stats.highest == 100.0


def test_integer_histogram_bins_are_centred_on_integers():
    edges, counts = histogram(np.array([10, 10, 11, 13], dtype=np.uint16), 9.0, 14.0, bins=64, integer=True)
    centres = 0.5 * (edges[:-1] + edges[1:])
    assert dict(zip(centres[counts > 0].tolist(), counts[counts > 0].tolist())) == {10.0: 2, 11.0: 1, 13.0: 1}


def test_histogram_counts_each_value_in_the_bin_its_edges_say():
    """Equal bins are counted directly (no sort of the values): each value lands where the
    returned edges put it, values on an edge included, for floats and wide integer bins."""
    rng = np.random.default_rng(3)
    cases = [(rng.normal(50.0, 7.0, 20001), 20.0, 80.0, 64, False),
             (np.linspace(0.0, 1.0, 65), 0.0, 1.0, 64, False),  # every value on an edge
             (rng.integers(0, 4096, 30001).astype(np.uint16), 0.0, 4095.0, 64, True)]
    for v, frm, to, bins, integer in cases:
        edges, counts = histogram(v, frm, to, bins, integer=integer)
        x = v.astype(np.float64)
        x = x[(x >= edges[0]) & (x <= edges[-1])]
        k = np.minimum(np.searchsorted(edges, x, side="right") - 1, edges.size - 2)  # last bin closed
        assert counts.tolist() == np.bincount(k, minlength=edges.size - 1).tolist()
        assert np.allclose(np.diff(edges), edges[1] - edges[0])


def test_fitted_numbers_come_from_the_engine_and_ignore_a_defect_tail():
    from ares.analysis.noise.panels import robust_gauss_fit

    rng = np.random.default_rng(1)
    v = np.concatenate([rng.normal(100.0, 2.0, 5000), np.full(50, 400.0)])  # 1 % hot pixels
    m = StatsPanelModel("MEAN SIGNAL")
    m.set_values(v)
    assert (m.stats.fitted_mean, m.stats.fitted_sigma) == robust_gauss_fit(v)
    assert m.stats.fitted_mean == pytest.approx(100.0, abs=0.2) and m.stats.fitted_sigma == pytest.approx(2.0, rel=0.1)
    assert m.stats.mean == pytest.approx(v.mean()) and m.stats.highest == 400.0


def test_percentile_range_drops_extreme_tails():
    v = np.arange(10001, dtype=float)  # 0..10000
    frm, to = auto_range(v, PERCENTILE)
    assert (frm, to) == pytest.approx((10.0, 9990.0))


def test_constant_values_give_unit_window_and_zero_sigma():
    m = StatsPanelModel("ROWS")
    m.set_values(np.full(10, 7.0))
    assert m.range == (6.5, 7.5)
    assert m.stats.sigma == 0.0 and m.stats.fitted_mean == 7.0


def test_bins_for():
    assert (bins_for(0), bins_for(20), bins_for(400), bins_for(10**6)) == (8, 9, 40, 64)


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, st.integers(1, 300), elements=st.floats(-1e6, 1e6)))
def test_auto_range_histogram_holds_every_value(values):
    m = StatsPanelModel("x")
    m.set_values(values)
    assert m.counts.sum() == values.size == m.stats.n
    assert m.range[0] <= m.stats.lowest <= m.stats.highest <= m.range[1]


# ---- regions and the RoA file ---------------------------------------------------------------
def test_region_clipping_and_crop():
    img = np.arange(12).reshape(3, 4)
    assert Region(True, False, 2, 1, 5, 5).crop(img).tolist() == [[6, 7], [10, 11]]
    assert Region(True, False, 10, 0, 2, 2).crop(img) is None
    assert Region(True, False, 0, 0, 0, 3).crop(img) is None


def test_regionset_add_active_drawn():
    rs = RegionSet()
    assert len(rs) == 16
    seen = []
    rs.subscribe(lambda m: seen.append(1))
    assert rs.add(Region(True, True, 4, 6, 128, 108)) == 0
    assert rs.add(Region(False, False, 49, 137, 86, 138)) == 1
    rs.update(1, on=True)
    assert [i for i, _ in rs.active()] == [0, 1]
    assert [i for i, _ in rs.drawn()] == [0]
    assert len(seen) == 3
    with pytest.raises(InputError):
        rs.update(0, width=-1)


@pytest.mark.parametrize("suffix", [".xml", ".csv"])
def test_roa_file_round_trip(tmp_path, suffix):
    regions = [Region(True, False, 4, 6, 128, 108), Region(True, True, 49, 137, 86, 138),
               Region(False, False, 143, 101, 140, 124)]
    path = tmp_path / f"r{suffix}"
    save_roa(path, regions)
    assert load_roa(path) == regions
    rs = RegionSet(regions)
    rs.save(path)
    rs2 = RegionSet()
    rs2.load(path)
    assert rs2.regions == rs.regions


def test_roa_file_errors_are_one_sentence_with_line(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text('<roa>\n  <region on="1" draw="0" x="a" y="0" width="1" height="1"/>\n</roa>\n')
    with pytest.raises(InputError, match=r"bad.xml, line 2: x='a' is not an integer\."):
        load_roa(bad)
    bad.write_text("<roa><region")
    with pytest.raises(InputError, match="not well-formed XML"):
        load_roa(bad)
    csvf = tmp_path / "bad.csv"
    csvf.write_text("on,draw,x,y,width,height\n1,0,1,2,3\n")
    with pytest.raises(InputError, match=r"bad.csv, line 2: region lacks height\."):
        load_roa(csvf)
    with pytest.raises(InputError, match="cannot read"):
        load_roa(tmp_path / "missing.xml")


# ---- profiles, PTC, defects, progress ----------------------------------------------------------
def test_profiles_hand_computed():
    img = np.arange(12, dtype=float).reshape(3, 4)  # [[0,1,2,3],[4,5,6,7],[8,9,10,11]]
    cols, rows = region_profiles(img, Region(True, False, 1, 0, 2, 2))
    assert cols.x.tolist() == [1, 2] and cols.y.tolist() == [3.0, 4.0]
    assert rows.x.tolist() == [0, 1] and rows.y.tolist() == [1.5, 5.5]


def test_ptc_model_skips_nonpositive_on_loglog():
    m = PTCModel()
    m.set_dark(100.0)
    m.add(2, "a", 10.0, 7.0)
    m.add(3, "b", 1000.0, 502.0)
    m.add(4, "c", -10.0, 3.0)  # below dark: not drawable on log axes
    x, y = m.xy()
    assert x.tolist() == [10.0, 1000.0, -10.0] and y.tolist() == [7.0, 502.0, 3.0]
    lx, ly = m.loglog()
    assert lx.tolist() == [1.0, 3.0] and ly == pytest.approx(np.log10([7.0, 502.0]))
    assert m.fit_line() is None
    m.set_fit(2.0)
    fx, fy = m.fit_line()
    assert fx.tolist() == [10.0, 1000.0] and fy.tolist() == [5.0, 500.0]


def test_defect_counts_ppm():
    m = DefectCountsModel()
    m.set_counts({"hot": 3, "dead": 0}, 1_000_000 // 4)
    assert [(r.name, r.count, r.ppm) for r in m.rows] == [("hot", 3, 12.0), ("dead", 0, 0.0)]


def test_format_remaining():
    assert P.format_remaining(3725) == "1 : 02 : 05"
    assert P.format_remaining(0) == "0 : 00 : 00"
    assert P.format_remaining(None) == "- : -- : --"
    pm = P.ProgressModel()
    assert pm.stage_text == P.IDLE_TEXT
    pm.update(stage=1, total=5, stage_name="dark")  # the stage index (from 0); the text is a count
    assert pm.stage_text == "2 of 5 (dark)"


# ---- the session model fed by a demo scan, without Qt --------------------------------------------
def test_session_follows_a_demo_scan():
    s = SessionModel()
    s.regions.add(Region(True, True, 2, 3, 10, 6))
    s.begin_run()
    DemoScan(shape=(12, 16), frames=3, levels_e=(0, 100, 400)).run(s.handle)
    assert s.progress.state == P.DONE and s.progress.stage_text == "3 of 3 (400 e-)"
    assert s.progress.remaining_text == "0 : 00 : 00"
    assert list(s.distributions) == [0] and s.distributions[0].counts.sum() == 60
    assert s.panels["MEAN SIGNAL"].stats.n == 60
    assert s.panels["COLUMNS"].stats.n == 10 and s.panels["ROWS"].stats.n == 6
    assert len(s.ptc.points) == 2 and s.ptc.dark_dn == pytest.approx(100, abs=2)
    x, y = s.ptc.xy()
    assert x == pytest.approx([50, 200], rel=0.1)  # 0.5 DN/e- x 100, 400 e-
    assert y == pytest.approx(0.5 * x, rel=0.5)  # shot noise: variance = K * signal (3 frames: loose)
    assert s.profiles.columns[0].x.tolist() == list(range(2, 12))
    assert s.signal_map.image.shape == (12, 16) and s.signal_map.rectangles[0][0] == 0


def test_session_uses_full_frame_without_regions_and_reports_defects():
    s = SessionModel()
    mean = np.full((4, 5), 10.0)
    s.handle(E.StageResult(1, "x", mean, np.ones((4, 5)), 2, defects={"hot": 2}))
    assert s.panels["MEAN SIGNAL"].stats.n == 20 and s.region_label((4, 5)) == "full frame"
    assert s.defects.rows[0].ppm == pytest.approx(1e5)
    s.handle(E.Failed("Camera 'sim0' stopped answering."))
    assert s.progress.state == P.FAILED and s.progress.message == "Camera 'sim0' stopped answering."


def test_demo_scan_stop_and_abort():
    events = []
    job = DemoScan(shape=(4, 4), frames=2, levels_e=(0, 10, 20))

    def emit(ev):
        events.append(ev)
        if isinstance(ev, E.StageResult):
            job.stop()

    job.run(emit)
    assert isinstance(events[-1], E.Stopped) and sum(isinstance(e, E.StageResult) for e in events) == 1

    job = DemoScan(shape=(4, 4), frames=2, levels_e=(0, 10))

    def emit_abort(ev):
        if isinstance(ev, E.FramePreview):
            job.abort()

    with pytest.raises(Interrupted):
        job.run(emit_abort)


# ---- sweep map ---------------------------------------------------------------------------------
def test_sweep_model_2d_grid_and_axes():
    from ares.gui.models.sweep import SweepModel, SweepPoint

    m = SweepModel()
    k = 0
    for i, bias in enumerate((1.0, 1.5, 2.0)):
        for j, tx in enumerate((-0.8, -0.2)):
            k += 1
            m.add(SweepPoint(k, "bias", (i, j), {"exposure": 0.01, "reg:sf_bias": bias, "reg:tx_low": tx},
                             {"noise (DN)": 10 * i + j}))
    assert m.ndim == 2 and m.quantities == ["noise (DN)"]
    (n1, v1), (n2, v2) = m.axes()
    assert (n1, v1.tolist(), n2, v2.tolist()) == ("sf_bias", [1.0, 1.5, 2.0], "tx_low", [-0.8, -0.2])
    assert m.grid().tolist() == [[0, 1], [10, 11], [20, 21]]


def test_sweep_model_1d_curve_follows_latest_group():
    from ares.gui.models.sweep import SweepModel, SweepPoint

    m = SweepModel()
    m.add(SweepPoint(1, "dark", (), {"light": 0.0}, {"mean (DN)": 64.0}))  # a single stage: no coords
    for i, light in enumerate((1e3, 1e4, 1e5)):
        m.add(SweepPoint(2 + i, "ptc", (i,), {"light": light, "exposure": 0.01}, {"mean (DN)": 64 + light / 100}))
    x, y = m.curve()
    assert m.axes()[0][0] == "light" and x.tolist() == [1e3, 1e4, 1e5] and y.tolist() == [74.0, 164.0, 1064.0]


def test_components_model_orders_rows_and_formats_estimates():
    from ares.gui.models.components import ComponentsModel

    m = ComponentsModel()
    m.set_stage("stage 2", {
        "full": {"components": {"Pt": {"value": 1.25, "se": 0.05, "unit": "DN^2"},
                                "o": {"value": 64.0, "se": None, "unit": "DN"},
                                "extra": {"value": None, "se": None, "unit": "", "note": "one frame"}}},
        "centre": {"components": {"Ps": {"value": 0.5, "se": 0.1, "unit": "DN^2"}}},
    })
    rows = m.rows()
    assert [r.symbol for r in rows] == ["o", "Pt", "extra"]  # model order first, then the rest
    assert [r.text for r in rows] == ["64", "1.250 ± 0.050", "n/a (one frame)"]  # digits from the SE
    assert rows[1].description == "pixel temporal variance (read)"
    m.select("centre")
    assert [r.symbol for r in m.rows()] == ["Ps"] and m.rows("dark_components") == []


def test_shown_tabs_are_redrawn_at_most_every_refresh_interval_during_a_scan():
    """While a scan runs the Results panels follow the newest stage at most every
    RESULTS_S (fake clock): a stage that comes sooner waits for flush(); the scan's end
    draws it at once. The run's first stage is drawn at once, even when the tab was
    drawn (empty) just before the run started."""
    from ares.gui.events import Done, StageResult
    from ares.gui.models.session import RESULTS_S, SessionModel

    s = SessionModel()
    now = [10.0]
    s.clock = lambda: now[0]
    s.set_visible({"Results"})
    s.throttle = True
    s._refresh_result()  # e.g. the view chosen as Start Scan is pressed: the empty tab drawn
    s.begin_run("t")
    now[0] += RESULTS_S / 10

    def stage(k, level):
        m = np.full((4, 5), float(level))
        m[0, 0] += 1.0
        return StageResult(k, f"s{k}", m, np.ones((4, 5)), 4)

    s.handle(stage(1, 100))
    assert s.panels["MEAN SIGNAL"].stats.highest == 101
    now[0] += RESULTS_S / 5
    s.handle(stage(2, 200))  # too soon: the panels still show stage 1 ...
    assert s.panels["MEAN SIGNAL"].stats.highest == 101
    s.flush()
    assert s.panels["MEAN SIGNAL"].stats.highest == 101
    now[0] += RESULTS_S
    s.flush()  # ... until the interval has passed
    assert s.panels["MEAN SIGNAL"].stats.highest == 201
    now[0] += RESULTS_S / 5
    s.handle(stage(3, 300))
    assert s.panels["MEAN SIGNAL"].stats.highest == 201
    s.handle(Done(None, {}))  # the end draws the newest at once
    assert s.panels["MEAN SIGNAL"].stats.highest == 301


def test_the_newest_stage_is_shown_at_most_every_refresh_interval_and_the_ptc_redrawn_once_per_stage():
    """While a scan runs, a stage result that comes within RESULTS_S of the last one shown
    waits (components, highlighted PTC point, maps) for flush(), and each stage moves the
    PTC (dark level, point, highlight) with one notification, not three; every point is
    still in the PTC model at once."""
    from ares.gui.events import Done, StageResult
    from ares.gui.models.session import RESULTS_S, SessionModel

    s = SessionModel()
    now = [10.0]
    s.clock = lambda: now[0]
    s.begin_run("t")
    redraws = []
    s.ptc.subscribe(lambda m: redraws.append(len(m.points)))

    def stage(k, dark=False):
        m = np.full((4, 5), 100.0 * k)
        return StageResult(k, f"s{k}", m, np.ones((4, 5)), 4, dark=dark,
                           ptc_point=None if dark else (100.0 * k, 30.0 * k),
                           components={"full": {"components": {}}})

    s.handle(stage(0, dark=True))
    s.handle(stage(1))
    assert redraws == [0, 1]  # one notification per stage
    assert ": s0 (" in s.components.caption  # stage 1 came too soon after stage 0
    now[0] += RESULTS_S / 5
    s.handle(stage(2))
    assert ": s0 (" in s.components.caption and s.ptc.highlighted == 0
    assert [p.stage for p in s.ptc.points] == [1, 2]  # the points are all there
    now[0] += RESULTS_S
    s.flush()
    assert ": s2 (" in s.components.caption and s.ptc.highlighted == 2
    now[0] += RESULTS_S / 5
    s.handle(stage(3))
    assert ": s2 (" in s.components.caption
    s.handle(Done(None, {}))  # the end shows the newest at once
    assert ": s3 (" in s.components.caption and s.ptc.highlighted == 3


def test_live_image_levels_hold_over_frame_noise_and_follow_a_new_light_level():
    from ares.gui.models.image import ImageModel, robust_levels

    rng = np.random.default_rng(4)
    frame = lambda level: rng.normal(level, 10.0, (120, 160))  # noqa: E731
    m = ImageModel("live")
    first = frame(1000.0)
    m.set_image(first)
    assert m.levels == robust_levels(first)
    for _ in range(5):  # the same light, new noise: the colour scale holds still
        m.set_image(frame(1000.0))
        assert m.levels == robust_levels(first)
    brighter = frame(1200.0)  # a new stage's level: followed at once
    m.set_image(brighter)
    assert m.levels == robust_levels(brighter)
    m.set_image(brighter, levels=(0.0, 4095.0))  # levels asked for are always shown
    assert m.levels == (0.0, 4095.0)


def test_results_panels_are_computed_by_the_session_s_executor_while_a_scan_runs():
    """With an executor (the window's thread), a stage's panels are computed there and
    shown at a flush once ready -- the same numbers as computed in place; a range mode
    chosen meanwhile is kept; ``settle`` (the scan thread's end) waits for them; once the
    executor is not available (no scan thread), they are computed in place."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from ares.gui.events import Done, StageResult
    from ares.gui.models.session import SessionModel

    rng = np.random.default_rng(6)
    mean, var = rng.normal(500.0, 5.0, (40, 50)), rng.normal(9.0, 0.5, (40, 50))
    ref = SessionModel()
    ref.handle(StageResult(1, "a", mean, var, 4))

    class Executor(ThreadPoolExecutor):
        on = True

        def available(self):
            return self.on

    gate = threading.Event()
    pool = Executor(1)
    s = SessionModel()
    s.executor = pool
    s.begin_run("t")
    pool.submit(gate.wait)  # the stats thread busy: the job waits behind it
    try:
        s.handle(StageResult(1, "a", mean, var, 4))
        assert s.panels["MEAN SIGNAL"].stats.n == 0 and s.panels_stage is None  # not computed here
        s.handle(StageResult(2, "b", mean + 1, var, 4))  # a newer stage, drawn later (RESULTS_S)
        s.panels["NOISE"].set_range_mode(MEAN_3_SIGMA)  # chosen while it is computed
        s.flush()
        assert s.panels["MEAN SIGNAL"].stats.n == 0  # not ready: not waited for
    finally:
        gate.set()
    assert s.last_result.stage == 2
    s._jobs["panels"].result(timeout=600)  # (a bound, not a speed requirement)
    s.flush()  # the poll timer's flush: stage 1's panels, shown as such
    assert s.panels_stage.stage == 1 and s.panels["MEAN SIGNAL"].stats == ref.panels["MEAN SIGNAL"].stats
    s.handle(Done(None, {}))  # the run's end (its newest stage drawn: in the executor too) ...
    s.settle()  # ... and the scan thread's: every panel computed is shown
    assert not s._jobs and s.panels_stage.stage == 2
    ref.handle(StageResult(2, "b", mean + 1, var, 4))
    for name in ("MEAN SIGNAL", "COLUMNS", "ROWS"):
        assert s.panels[name].stats == ref.panels[name].stats, name
        assert s.panels[name].counts.tolist() == ref.panels[name].counts.tolist()
    assert s.panels["NOISE"].range_mode == MEAN_3_SIGMA
    ref.panels["NOISE"].set_range_mode(MEAN_3_SIGMA)
    assert s.panels["NOISE"].stats == ref.panels["NOISE"].stats
    pool.on = False  # no scan thread: in place
    s.select_view("full")
    assert not s._jobs and s.panels["MEAN SIGNAL"].stats == ref.panels["MEAN SIGNAL"].stats
    pool.shutdown()


def test_a_failing_panel_computation_is_logged_and_the_run_s_end_still_comes(monkeypatch, caplog):
    """A bug in the statistics, in the executor: ``settle`` (which the scan thread's end
    waits on) logs it and returns; the panels keep what they showed."""
    from concurrent.futures import ThreadPoolExecutor

    from ares.gui.events import StageResult
    from ares.gui.models import stats
    from ares.gui.models.session import SessionModel

    class Executor(ThreadPoolExecutor):
        def available(self):
            return True

    def broken(*a, **k):
        raise FloatingPointError("a bug")

    monkeypatch.setattr(stats, "panel_state", broken)
    pool = Executor(1)
    s = SessionModel()
    s.executor = pool
    s.begin_run("t")
    s.handle(StageResult(1, "a", np.ones((4, 5)), np.ones((4, 5)), 4))
    s.settle()
    assert not s._jobs and s.panels["MEAN SIGNAL"].stats.n == 0
    assert "statistics could not be computed" in caplog.text and "a bug" in caplog.text
    pool.shutdown()


def test_sweep_model_shows_a_shuffled_axis_in_order():
    """An axis taken in shuffled order (``<axis order="shuffled">``): the curve and the map run in
    increasing value, not in the order the stages were taken."""
    from ares.gui.models.sweep import SweepModel, SweepPoint

    m = SweepModel()
    for i, e in enumerate((0.5, 0.1, 1.0, 0.3)):
        m.add(SweepPoint(1 + i, "dark", (i,), {"exposure": e}, {"mean (DN)": 64 + 2 * e}))
    x, y = m.curve()
    assert x.tolist() == [0.1, 0.3, 0.5, 1.0] and y.tolist() == [64.2, 64.6, 65.0, 66.0]
    m = SweepModel()
    for i, a in enumerate((2.0, 1.0)):
        for j, b in enumerate((-0.2, -0.8, -0.5)):
            m.add(SweepPoint(10 + 3 * i + j, "bias", (i, j), {"reg:sf_bias": a, "reg:tx_low": b}, {"n": 10 * a + b}))
    (_, v1), (_, v2) = m.axes()
    assert v1.tolist() == [1.0, 2.0] and v2.tolist() == [-0.8, -0.5, -0.2]
    assert np.allclose(m.grid(), 10 * v1[:, None] + v2[None, :])


def test_auto_range_of_a_spread_no_histogram_resolves():
    """Found by the property test above: two values a subnormal apart gave a window no 8-bin
    histogram can split (numpy: "Too many bins for data range")."""
    m = StatsPanelModel("x")
    m.set_values(np.array([5e-324, 0.0]))
    assert m.counts.sum() == 2 and m.range[0] <= 0.0 and m.range[1] >= 5e-324
