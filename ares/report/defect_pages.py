"""Report pages of a scan's defect and ADC analyses: defect counts per class, the defect map, ADC INL/DNL."""

from __future__ import annotations

import numpy as np
from ares.report import plots
from ares.report.plots import new_page, text_table
from ares.report.page_tables import _table, analysis_rows
from ares.report import series_tables


def defects_page(run, d: dict):
    counts = {k: v for k, v in (d.get("counts") or {}).items()}
    fig = new_page("Defects", plots.clip(f"dark stages: {', '.join(d.get('dark_stages') or [])}; flat stage: "
                                         f"{d.get('flat_stage') or '-'}", 130))
    n_pix = None
    if run.stages:
        n_pix = run.stages[0]["views"]["full"]["level"].get("n_pixels")
    why = d.get("unavailable") if isinstance(d.get("unavailable"), dict) else {}
    na = (lambda k: "n/a: why under detection limits, next page") if d.get("shape") else (  # (the map page has it)
        lambda k: "n/a: " + plots.clip(why.get(k) or "not tested by this scan", 60))
    rows = [[k.replace("_", " "), na(k) if v is None else str(v),
             "" if v is None or not n_pix or k in ("bad_columns", "bad_rows", "clusters") else f"{1e6 * v / n_pix:.1f}"]
            for k, v in counts.items()]
    y = text_table(fig, (0.08, 0.92, 0.84), ["class", "count", "ppm of pixels"], rows, [0.4, 0.3, 0.3],
                   fontsize=9, title="defect counts")
    lim = d.get("limits") or []
    fig.text(0.08, y - 0.01, "limits: " + ("; ".join(map(str, lim)) if lim else "none set")
             + f"  --  {'passed' if d.get('passed', True) else 'FAILED'}", fontsize=9, va="top",
             color="C2" if d.get("passed", True) else "C3")
    ks = [k for k, v in counts.items() if v is not None and k != "total"]
    if ks and y > 0.45:
        h = min(0.3, y - 0.15)
        ax = fig.add_axes([0.2, y - 0.07 - h, 0.74, h])
        ax.barh(ks, [counts[k] for k in ks], color="C0")
        ax.set_xlabel("count")
        ax.grid(alpha=0.3, axis="x")
        ax.invert_yaxis()
    return fig


def defect_map_page(run, d: dict):
    """Where the defects are, one marker per class, bad columns/rows as lines; below, what
    each class can detect with this run's frames (its criterion) or why it is not available."""
    rows, cols = d["shape"]
    fig = new_page("Defect map", f"{cols} x {rows} pixels; classes from the dark stage(s) "
                   f"{', '.join(d.get('dark_stages') or [])}")
    ax = fig.add_axes([0.08, 0.42, 0.68, 0.46])
    ax.set_xlim(-0.5, cols - 0.5)
    ax.set_ylim(rows - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_facecolor("0.97")
    marks = {"hot": ("o", "C3"), "warm": ("o", "C1"), "dead": ("s", "k"), "stuck": ("x", "C4"), "noisy": ("^", "C0"),
             "rts": ("v", "C9"), "low_response": ("s", "C5"), "high_response": ("D", "C2")}
    for cls, pts in (d.get("locations") or {}).items():
        if pts:
            a = np.asarray(pts)
            m, c = marks.get(cls, (".", "0.3"))
            shown = len(pts)
            total = (d.get("counts") or {}).get(cls) or shown
            ax.scatter(a[:, 0], a[:, 1], s=14, marker=m, color=c, lw=0.8,
                       label=f"{cls.replace('_', ' ')} ({total}" + (f", {shown} shown)" if shown < total else ")"))
    for x in d.get("bad_column_x") or []:
        ax.axvline(x, color="C3", lw=0.8, alpha=0.7)
    for y in d.get("bad_row_y") or []:
        ax.axhline(y, color="C3", lw=0.8, alpha=0.7)
    if d.get("bad_column_x") or d.get("bad_row_y"):
        ax.plot([], [], color="C3", lw=0.8, label="bad column / row")
    ax.set_xlabel("column")
    ax.set_ylabel("row")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False, borderaxespad=0)
    else:
        ax.text(0.5, 0.5, "no defective pixels found", ha="center", transform=ax.transAxes)
    crit = [[k.replace("_", " "), plots.clip(v, 125)] for k, v in (d.get("detection") or {}).items()]
    crit += [[k.replace("_", " "), plots.clip("not available: " + v, 125)] for k, v in (d.get("unavailable") or {}).items()]
    if crit:
        text_table(fig, (0.06, 0.34, 0.9), ["class", "criterion with this run's frames"], crit, [0.12, 0.88],
                   fontsize=6.5, title="detection limits")
    return fig


def adc_page(run, d: dict):
    """INL/DNL per channel: the runner's extremes and -- from the ramp stages' code
    histograms in results.h5 -- the curves (code-density test, as the runner)."""
    fig = new_page("ADC linearity: INL and DNL", "code-density test on the ramp stage(s): "
                   + ", ".join(d.get("stages") or []))
    curves = series_tables.adc_curves(run, d)
    y = 0.92
    if curves:
        ax1 = fig.add_axes([0.11, 0.66, 0.83, 0.25])
        ax2 = fig.add_axes([0.11, 0.35, 0.83, 0.25], sharex=ax1)
        for k, (ch, r) in enumerate(curves.items()):
            ax1.plot(r.codes, r.dnl, lw=0.6, label=ch, color=f"C{k}")
            se = r.dnl_se()  # 1-SE bands, as adc_inl_dnl.csv gives every code's SE (InlDnl.se_note)
            ax1.fill_between(r.codes, r.dnl - se, r.dnl + se, color=f"C{k}", alpha=0.15, lw=0)
            t = np.arange(1, r.inl.size + 1)
            ax2.plot(t, r.inl, lw=0.8, label=ch, color=f"C{k}")
            se = r.inl_se()
            ax2.fill_between(t, r.inl - se, r.inl + se, color=f"C{k}", alpha=0.15, lw=0)
        ax1.set_ylabel("DNL (LSB)")
        ax1.set_title("differential non-linearity")
        ax2.set_ylabel("INL (LSB)")
        ax2.set_xlabel("code")
        how = ("the sub-histograms' scatter" if all(r.scatter for r in curves.values())
               else "counting statistics: no sub-histograms")
        ax2.set_title(f"integral non-linearity (endpoint fit; band: 1 SE, {how})")
        for a in (ax1, ax2):
            a.grid(alpha=0.3)
            a.legend()
        y = 0.27
    else:
        fig.text(0.08, y, "no code histograms in results.h5: curves not available", fontsize=9, va="top")
        y -= 0.03
    chans, again = series_tables.adc_channels_now(d, curves)
    _table(fig, y, analysis_rows(chans), "per channel (scan_results.json" + (
        "; the extremes judged again from results.h5: no sub-histograms, counting SE)" if again else ")"), n=16)
    return fig
