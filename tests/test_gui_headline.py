"""The headline figures head the Information tab (issue 38: they were at rows 17-21), in
the order and wording of the terminal's summary (one list: ares.labels.PTC_FIGURES and
HEADLINE_COMPONENTS)."""

from __future__ import annotations

import io
import os
from types import SimpleNamespace

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6")
pytest.importorskip("pyqtgraph")

from test_gui import show_tab, window  # noqa: E402,F401 (fixture)

pytestmark = pytest.mark.gui


def _results() -> dict:
    from ares.analysis.stats.estimate import Estimate
    from ares.labels import PTC_FIGURES

    units = {"conversion_gain_uv_per_e": "uV/e-", "gain_dn_per_e": "DN/e-", "gain_e_per_dn": "e-/DN",
             "dynamic_range_db": "dB", "turnoff_dn": "DN", "read_noise_dn": "DN"}
    ptc = {key: Estimate(1.2345 * (i + 1), 0.0123 * (i + 1), units.get(key, "e-")).to_dict()
           for i, (key, _) in enumerate(PTC_FIGURES)}
    ptc["saturation_capacity_e"] = Estimate.na("no level at saturation").to_dict()  # n/a + its reason
    comps = {"o": Estimate(64.6, 0.2, "DN").to_dict(), "Ps": Estimate(0.0815, 0.0024, "DN^2").to_dict(),
             "Pt": Estimate(0.82, 0.003, "DN^2").to_dict(), "Pg": Estimate(2.5e-5, 1e-6, "1").to_dict()}  # engine order
    return {"ptc": ptc, "decomposition": {"stage": 3, "settings": {"exposure_s": 0.01}, "components": comps}}


def test_headline_figures_head_the_information_tab_as_the_terminal_prints_them(window):  # noqa: F811
    from ares.commands.run import print_summary
    from ares.gui.events import Done
    from ares.gui.models.session import HEADLINE
    from ares.gui.runner_adapter import summarize

    res = _results()
    out = io.StringIO()
    print_summary(SimpleNamespace(scan_results=res, stages=[], status="done", seed=None, run_dir=None,
                                  limit_failures=[]), SimpleNamespace(name="t", limits=()), 1.0, out=out)
    terminal = out.getvalue().splitlines()
    window.session.info.update({"run directory": "/somewhere", "scan": "t.xml"})
    window.session.handle(Done(summary=summarize(res)))
    show_tab(window, "Information")
    rows = window.info.rows()
    head = [k for k, _ in rows[:len(HEADLINE)]]
    assert head == list(HEADLINE), head  # all of them, first, in the one order
    at = []
    for name, value in rows[:len(HEADLINE)]:
        label = name.removeprefix("PTC: ").split(" [")[0].rsplit(", ", 1)[0]  # "DSNU (...), e-": the unit
        lines = [i for i, line in enumerate(terminal) if label in line and value in line]
        assert lines, (name, value, terminal)  # the terminal's wording and digits
        at.append(lines[0])
    assert at == sorted(at)  # ... in the terminal's order
    assert dict(rows)["PTC: saturation capacity"].startswith("n/a (no level at saturation")
