"""The Fe-55 report page, one per dark stage of an ``fe55`` scan: the histogram of the events'
3x3 signals in the fit window with the fitted K-alpha + K-beta model (``ares.analysis.lowlight.fe55``),
the residuals, and a table of the K-alpha peak, line width, K-beta/K-alpha, the gain (inverse
system gain 1/K, ``ares.labels``) with its SE and the pair energy's systematic apart, the events by
grade against the declared threshold, and the charge-transfer trend. Frames without X-ray events
get the sentence that says so instead of the plot. Drawn from ``scan_results.json``; nothing is
re-measured."""

from __future__ import annotations

import math
import textwrap

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.labels import FIGURES
from ares.report.plots import histogram_residuals, new_page, text_table

ROWS = (("kalpha_dn", "K-alpha peak (3x3 signal)"), ("kalpha_sigma_dn", "K-alpha line width (sigma)"),
        ("kbeta_ratio", "K-beta / K-alpha peak heights"),
        ("gain_e_per_dn", f"{FIGURES['gain_e_per_dn'][0]} (Fe-55 K-alpha)"),
        ("transfer_per_row", "charge transfer: signal change per row"),
        ("transfer_per_col", "charge transfer: signal change per column"))


def fe55_page(stage: str, d: dict):
    t = d.get("temperature_c")
    xray = d.get("xray_events", True)
    fig = new_page(f"Fe-55 X-ray gain: stage {stage}",
                   f"events above {d.get('threshold_dn', math.nan):.4g} DN, Mn K-alpha ({d.get('line_ev', 5889):g} eV) "
                   f"and K-beta {'fitted' if xray else 'not found'}; {d.get('electrons_per_kalpha', math.nan):.1f} e- "
                   f"per K-alpha at {t:g} C")
    hist = d.get("histogram")
    y0 = 0.9
    if xray and hist:
        x = np.asarray(hist["centres_dn"], float)
        h = np.asarray(hist["counts"], float)
        m = np.asarray(hist["model"], float)
        w = float(np.median(np.diff(x))) if x.size > 1 else 1.0
        ax = fig.add_axes([0.11, 0.6, 0.83, 0.31])
        ax.bar(x, h, width=w, color="0.75", label="events")
        chi2 = d.get("chi2_dof")
        ax.plot(x, m, "-", color="C3", lw=1.2, label="K-alpha + K-beta fit" + (f" (chi2/dof {chi2:.2f})" if chi2 else ""))
        k = Estimate.from_dict(d["kalpha_dn"])
        if k.available:
            ax.axvline(k.value, color="C0", lw=0.8, ls="--", label=f"K-alpha {k.text()}")
            ax.axvline(k.value * 6490 / 5889, color="C1", lw=0.8, ls=":", label="K-beta (6490/5889 of K-alpha)")
        ax.set_ylabel("events per bin")
        ax.legend(loc="upper right", fontsize=7.5)
        ax.grid(alpha=0.3)
        histogram_residuals(fig, [0.11, 0.46, 0.83, 0.11], ax, x, h, m, "event signal, sum of 3x3 pixels (DN)")
        y0 = 0.4
    elif d.get("no_xray"):
        fig.text(0.08, 0.9, textwrap.fill(d["no_xray"][0].upper() + d["no_xray"][1:] + ".", 95), fontsize=10,
                 va="top", color="C3")
        y0 = 0.8
    rows = []
    for key, name in ROWS:
        if key in d:
            e = Estimate.from_dict(d[key])
            rows.append([name, e.text(), e.verdict if e.available else ("no X-ray events (above)" if not xray else e.note)])
    g = Estimate.from_dict(d["gain_e_per_dn"]) if "gain_e_per_dn" in d else None
    if g is not None and g.available and d.get("gain_systematic_rel"):
        rel = d["gain_systematic_rel"]
        rows.append(["pair-energy systematic of the gain", f"± {g.value * rel:.2g} e-/DN ({100 * rel:.1f} %)",
                     "Lowe & Sareen 2007; not in the SE"])
    if "single" in d:
        rows.append(["events", f"{d['single']} single-pixel, {d['split']} split", f"{d.get('frames')} frames"])
        rows.append(["event threshold / split threshold", f"{d['threshold_dn']:.4g} / {d['split_dn']:.4g} DN",
                     f"noise {d['noise_dn']:.3g} DN"])
    rows.append(["events in the fit window", f"{d.get('events_in_fit')} of {d.get('events_total')}",
                 "window {:.4g}-{:.4g} DN".format(*d["fit_window_dn"]) if all(
                     isinstance(v, (int, float)) for v in d.get("fit_window_dn") or [None]) else ""])
    text_table(fig, (0.06, y0, 0.9), ["quantity", "value ± SE", "verdict"], rows, [0.36, 0.3, 0.34], fontsize=7.5,
               title="Fe-55 figures", max_chars=[46, 38, 60])
    return fig
