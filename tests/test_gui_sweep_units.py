"""The Sweep Map shows the gain spreads (PRNU Pg, row/column Rg/Cg) in % rms, as the CLI
and the PDF do (issue 34): it showed their relative variance with unit "1" (9.97e-05 where
the terminal said 1.00 % rms). Checked on what the tab draws: the quantity chooser, the
curve's axis label and its tick labels."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from test_gui_ticks import _shown, drawn  # noqa: E402

pytestmark = pytest.mark.gui


def _view(pg_relvar: float) -> dict:
    return {"level": {"mean_dn": 1000.0, "var_dn2": 300.0},
            "components": {"Pg": {"value": pg_relvar, "se": 0.02 * pg_relvar, "unit": "1"},
                           "Rg": {"value": -1e-7, "se": 5e-7, "unit": "1"},
                           "G": {"value": 0.28, "se": 0.001, "unit": "DN/e-"}}}


def test_sweep_map_draws_prnu_in_percent_rms(qtbot):
    from ares.analysis.stats.estimate import component_text
    from ares.gui.models.sweep import SweepModel, SweepPoint
    from ares.gui.plots.sweep_view import SweepView
    from ares.gui.runner_adapter import quantities

    relvar = [0.9e-4, 1.0816e-4, 1.21e-4]  # 0.95, 1.04, 1.10 % rms
    m = SweepModel()
    view = _shown(qtbot, SweepView(m), 790, 500)
    for i, v in enumerate(relvar):
        m.add(SweepPoint(i, "bias", (i,), {"reg:sf_bias": 1.0 + 0.1 * i}, quantities(_view(v))))
    label = next(q for q in m.quantities if q.startswith("Pg: "))
    assert label.endswith(", % rms"), label
    assert not any(q.endswith(", 1") for q in m.quantities), m.quantities  # no gain spread as a bare variance
    view.quantity.setCurrentText(label)
    qtbot.waitUntil(lambda: m.quantity == label)
    x, y = m.curve()
    np.testing.assert_allclose(y, [100 * math.sqrt(v) for v in relvar])
    # the number the terminal prints for the middle point, digits as its SE allows
    assert component_text("Pg", _view(relvar[1])["components"]["Pg"]).startswith(f"{y[1]:.2f}")
    axis = view.curve_plot.getAxis("left")
    assert "% rms" in axis.labelText
    ticks = [float(t.replace("\u2212", "-")) for _, t in drawn(axis)]
    assert ticks and all(0.5 < t < 1.5 for t in ticks), ticks  # percent, not 1e-4
    # a spread estimated below 0 has no rms: not drawn as a number
    rg = next(q for q in m.quantities if q.startswith("Rg: "))
    assert rg.endswith("% rms") and all(math.isnan(p.values[rg]) for p in m.points)
