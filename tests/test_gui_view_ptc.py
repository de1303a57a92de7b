"""The View selector drives the PTC and Sweep Map tabs too (issue 38: it showed the full frame whatever was
chosen). On a sensor whose second ADC channel has 1.5x the gain, the adc1 view's photon
transfer has 1.5x the slope of adc0's (the simulator's truth), a region's points are its own
pixels', and the engine's fit verdicts (of the full frame) are drawn in the full-frame view only."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from test_gui import FIXTURES, PTC_SMALL, run_to_end, show_tab, window  # noqa: E402,F401 (fixture)

from ares.gui.models import progress as P  # noqa: E402

pytestmark = pytest.mark.gui
ADC1_GAIN = 1.5


def _two_gain_ptc(tmp_path) -> str:
    system = open(os.path.join(FIXTURES, "small", "sim_small.xml")).read().replace(
        '<param name="hot_rate_ppm" type="float" value="0"/>',
        '<param name="hot_rate_ppm" type="float" value="0"/>\n'
        f'    <param name="adc_gain" type="floats" value="1 {ADC1_GAIN:g}"/>')
    (tmp_path / "sim_2gain.xml").write_text(system)
    scan = open(PTC_SMALL).read().replace('href="sim_small.xml"', 'href="sim_2gain.xml"').replace(
        '<output raw_frames="true"/>', '<output raw_frames="false" hdf5="false" csv="false" pdf="false"/>').replace(
        "<frames>4</frames>", "<frames>8</frames>")
    (tmp_path / "ptc_2gain.xml").write_text(scan)
    return str(tmp_path / "ptc_2gain.xml")


def _slope(points) -> float:
    """variance / signal = K in DN/e- (shot-noise-limited levels: signal > 50 DN, unclipped)."""
    return float(np.median([p.variance_dn2 / p.signal_dn for p in points if 50 < p.signal_dn < 2000]))


def test_the_ptc_tab_shows_the_view_chosen_in_the_view_bar(window, qtbot, tmp_path):  # noqa: F811
    assert window.load_scan(_two_gain_ptc(tmp_path))
    window.controls.output.directory.setText(str(tmp_path / "runs"))
    run_to_end(qtbot, window)
    s = window.session
    assert s.progress.state == P.DONE, s.progress.message
    show_tab(window, "PTC")

    window.view_bar.choose_view("full")
    assert s.ptc.view == "full" and s.ptc.fitted
    full = list(s.ptc.points)
    assert len(full) == 8 and "fit" in s.ptc.groups()  # the engine's verdicts: the full frame's
    assert "full frame" in window.ptc.caption.text()

    slopes = {}
    for k in (0, 1):
        window.view_bar.choose_view(f"adc{k}")
        assert s.ptc.view == f"adc{k}" and not s.ptc.fitted
        assert len(s.ptc.points) == 8 and s.ptc.points != full
        assert set(s.ptc.groups()) == {"view"}  # drawn as this view's levels, not as fitted
        drawable = sum(p.signal_dn > 0 and p.variance_dn2 > 0 for p in s.ptc.points)  # (log axes)
        assert drawable >= 6 and len(window.ptc.sets["view"].xData) == drawable  # what the tab draws
        assert f"adc{k}" in window.ptc.caption.text()
        slopes[k] = _slope(s.ptc.points)
    assert slopes[1] / slopes[0] == pytest.approx(ADC1_GAIN, rel=0.1), slopes

    # the Sweep Map follows the same choice: each ADC channel's mean signal (1.5x the gain: 1.5x the signal)
    show_tab(window, "Sweep Map")
    means = {}
    for k in (0, 1):
        window.view_bar.choose_view(f"adc{k}")
        window.sweep.quantity.setCurrentText("mean output (DN, offset included)")
        assert f"view 'adc{k}'" in window.sweep.caption.text()
        means[k] = window.session.sweep.curve()[1]
    signal = (means[1][1:] - means[1][0]) / (means[0][1:] - means[0][0])  # above the sweep's first (dimmest) level
    assert np.median(signal[1:5]) == pytest.approx(ADC1_GAIN, rel=0.05), signal

    # a region: its own pixels' signal, from the stage arrays the window holds
    window.view_bar.choose_view("roa0")
    assert s.ptc.view == "centre"
    dark = s.stages.results[0].mean.astype(np.float64)[6:18, 8:24].mean()  # stage 0: the dark
    for p in s.ptc.points:
        ev = s.stages.results[p.stage]
        assert p.signal_dn == pytest.approx(ev.mean.astype(np.float64)[6:18, 8:24].mean() - dark, rel=1e-3, abs=0.05)
