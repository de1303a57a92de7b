"""The low-light views of a finished run, from its ``scan_results.json``: the RTN map (each RTN
pixel at its position, coloured by its amplitude) with the RTN figures, and per Fe-55 stage the
event histogram with the fitted K-alpha/K-beta model and the gain -- or the sentence saying the
frames held no X-ray events. ``show_for_run`` adds the "Low Light" tab after a run that has
them and removes it after one that has not; the figures are worded as the report page's
(``ares.report.lowlight_pages``, ``ares.report.fe55_page``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyqtgraph as pg
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from ares.analysis.stats.estimate import Estimate
from ares.gui.plots import plain_axes
from ares.labels import FIGURES

TAB = "Low Light"


def lowlight_results(run_dir) -> dict:
    """{"rtn": ..., "fe55": {stage: ...}} of the run's scan-level results that have a map or a
    fit to show ({} when none, or the file is missing or unreadable)."""
    try:
        doc = json.loads((Path(run_dir) / "scan_results.json").read_text())
    except (OSError, ValueError, TypeError):
        return {}
    a = doc.get("analyses") if isinstance(doc, dict) else None
    if not isinstance(a, dict):
        return {}
    out = {}
    r = a.get("rtn")
    if isinstance(r, dict) and isinstance(r.get("map"), dict):
        out["rtn"] = r
    f = a.get("fe55")
    stages = {k: v for k, v in (f.get("stages") or {}).items() if isinstance(v, dict) and "kalpha_dn" in v} \
        if isinstance(f, dict) else {}
    if stages:
        out["fe55"] = stages
    return out


def _label(text: str) -> QLabel:
    w = QLabel(text)
    w.setWordWrap(True)
    return w


def _text(d) -> str:
    return Estimate.from_dict(d).text(with_reason=True) if isinstance(d, dict) else "n/a"


class LowlightView(QWidget):
    def __init__(self, results: dict, parent=None) -> None:
        super().__init__(parent)
        lay = QVBoxLayout(self)
        self.rtn_plot = self.fe55_plots = None
        r = results.get("rtn")
        if r:
            mp = r["map"]
            lay.addWidget(_label(
                f"RTN pixels: {r.get('rtn_pixels')} of {r.get('pixels')} ({_text(r.get('rtn_fraction'))}), "
                f"{r.get('frames')} frames of stage {r.get('stage')}; median amplitude "
                f"{_text(r.get('median_amplitude_dn'))}; dwell SE median {r.get('dwell_se_median_pct', float('nan')):.3g} %"
                + (f", dwell times to 10 % need >= {r['dwell_frames_needed']} frames"
                   if r.get("dwell_frames_needed", 0) > (r.get("frames") or 0) else "")))
            self.rtn_plot = pg.PlotWidget(title="RTN map: amplitude (DN)")
            plain_axes(self.rtn_plot)
            amp = np.asarray(mp.get("amplitude") or [], float)
            if amp.size:
                cmap = pg.colormap.get("viridis")
                lo, hi = float(amp.min()), float(amp.max())
                colors = cmap.mapToQColor((amp - lo) / (hi - lo) if hi > lo else np.zeros_like(amp))
                self.rtn_plot.addItem(pg.ScatterPlotItem(x=np.asarray(mp["cols"], float), y=np.asarray(mp["rows"], float),
                                                         brush=colors, pen=None, size=6))
                self.rtn_plot.setTitle(f"RTN map: amplitude {lo:.3g} (dark) to {hi:.3g} DN (yellow)")
            rows, cols = mp["shape"]
            self.rtn_plot.setXRange(-0.5, cols - 0.5)
            self.rtn_plot.setYRange(-0.5, rows - 0.5)
            self.rtn_plot.invertY(True)
            self.rtn_plot.setAspectLocked(True)
            self.rtn_plot.setLabel("bottom", "column")
            self.rtn_plot.setLabel("left", "row")
            lay.addWidget(self.rtn_plot, 1)
        self.fe55_plots = {}
        for stage, d in (results.get("fe55") or {}).items():
            if not d.get("xray_events", True):
                lay.addWidget(_label(f"Fe-55, stage {stage}: {d.get('no_xray', 'no X-ray events')}."))
                continue
            lay.addWidget(_label(f"Fe-55, stage {stage}: K-alpha {_text(d.get('kalpha_dn'))}; "
                                 f"{FIGURES['gain_e_per_dn'][0]} (Fe-55 K-alpha) {_text(d.get('gain_e_per_dn'))} at "
                                 f"{d.get('temperature_c')} C"))
            h = d.get("histogram")
            if not h:
                continue
            p = pg.PlotWidget(title=f"Fe-55 events, stage {stage}")
            plain_axes(p)
            x, n = np.asarray(h["centres_dn"], float), np.asarray(h["counts"], float)
            w = float(np.median(np.diff(x))) if x.size > 1 else 1.0
            p.addItem(pg.BarGraphItem(x=x, height=n, width=w, brush=(190, 190, 190), pen=None))
            p.plot(x, np.asarray(h["model"], float), pen=pg.mkPen((200, 30, 30), width=2), name="K-alpha + K-beta fit")
            p.setLabel("bottom", "event signal, sum of 3x3 pixels (DN)")
            p.setLabel("left", "events per bin")
            self.fe55_plots[stage] = p
            lay.addWidget(p, 1)


def show_for_run(tabs, run_dir) -> LowlightView | None:
    """Replace the "Low Light" tab of ``tabs`` (a QTabWidget) by the run's, or remove it when the run
    has no RTN map or Fe-55 fit."""
    for i in range(tabs.count()):
        if tabs.tabText(i) == TAB:
            w = tabs.widget(i)
            tabs.removeTab(i)
            w.deleteLater()
            break
    results = lowlight_results(run_dir) if run_dir else {}
    if not results:
        return None
    view = LowlightView(results)
    tabs.addTab(view, TAB)
    return view
