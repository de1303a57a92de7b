"""The window's "Low Light" tab (``ares.gui.plots.lowlight_view``): after a run whose
scan_results.json holds an RTN map or an Fe-55 fit it shows them (every RTN pixel, the Fe-55
histogram and fit the analysis made, the no-X-ray sentence), after any other run it is gone."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pg = pytest.importorskip("pyqtgraph")

from PySide6.QtWidgets import QLabel, QTabWidget  # noqa: E402

from ares.analysis.lowlight import fe55  # noqa: E402
from ares.gui.plots.lowlight_view import TAB, show_for_run  # noqa: E402

pytestmark = pytest.mark.gui


def _stage(res: dict) -> dict:
    """An fe55.analyse result as the scan's fe55 analysis stores it (ares.results.lowlight)."""
    out = {k: (v.to_dict() if hasattr(v, "to_dict") else v) for k, v in res.items() if not k.startswith("_")}
    x, h, m = res["_fit"].hist
    if len(x):
        out["histogram"] = {"centres_dn": [float(v) for v in x], "counts": [int(v) for v in h],
                            "model": [float(v) for v in m]}
    return json.loads(json.dumps(out, default=lambda v: None if isinstance(v, float) else str(v)).replace("NaN", "null"))


def test_low_light_tab_follows_the_run(qtbot, tmp_path):
    rng = np.random.default_rng(3)
    sig = np.concatenate([rng.normal(2000, 20, 3000), rng.normal(2000 * 6490 / 5889, 20, 450)])
    good = _stage(fe55.analyse(sig, -20.0))
    none = fe55.Events(*(np.empty(0, t) for t in (np.int64, np.int64, float, float, np.int64, np.int8)), 5.0, 3.0,
                       1.0, 10)
    empty = _stage(fe55.analyse(none.signal_dn, -20.0, none, threshold_sigma=5.0))
    rtn = {"rtn_pixels": 3, "pixels": 400, "frames": 1000, "stage": "dark",
           "map": {"shape": [20, 20], "rows": [1, 5, 9], "cols": [2, 4, 19], "amplitude": [3.0, 4.5, 6.0]}}
    (tmp_path / "scan_results.json").write_text(json.dumps(
        {"analyses": {"rtn": rtn, "fe55": {"stages": {"xray": good, "dark": empty}}}}))
    tabs = QTabWidget()
    qtbot.addWidget(tabs)
    v = show_for_run(tabs, tmp_path)
    assert [tabs.tabText(i) for i in range(tabs.count())] == [TAB]
    pts = [i for i in v.rtn_plot.getPlotItem().items if isinstance(i, pg.ScatterPlotItem)][0]
    assert sorted(zip(pts.data["y"], pts.data["x"])) == [(1, 2), (5, 4), (9, 19)]
    bars = [i for i in v.fe55_plots["xray"].getPlotItem().items if isinstance(i, pg.BarGraphItem)][0]
    assert sum(bars.opts["height"]) == good["events_in_fit"] and "dark" not in v.fe55_plots
    text = " ".join(w.text() for w in v.findChildren(QLabel))
    assert "inverse system gain 1/K (Fe-55 K-alpha)" in text and "No X-ray events found" not in text
    assert "no X-ray events found: 0 candidate events above the threshold 5 DN" in text
    other = tmp_path / "other"
    other.mkdir()
    (other / "scan_results.json").write_text(json.dumps({"analyses": {"ptc": {}}}))
    assert show_for_run(tabs, other) is None and tabs.count() == 0
