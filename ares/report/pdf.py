"""The PDF report of a run directory (matplotlib PdfPages, A4 portrait).

Pages, each only when the run has the data: title + key figures; photon transfer
(variance vs signal, log-log noise zones) per analog gain; SNR and linearity; the 13
components of the mid-level stage and of the dark stage; signal/noise maps with
histograms; dark signal vs exposure (and temperature); gain vs analog gain; 2-D sweep
maps; frame means per stage (lag, drift); every other scan-level analysis; the stage
list. ``write_pdf`` returns the page titles in order.
"""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path

import matplotlib
import numpy as np

from ares.report import plots, tables
from ares.report.plots import new_page, text_table


def _kf_rows(kf: dict) -> list[list[str]]:
    return [[v["label"], tables.fmt_value(v["value"], v["se"], v["unit"]), v.get("note") or ""]
            for v in kf.values()]


def title_page(run, kf: dict) -> "plots.Figure":
    m = run.meta
    fig = new_page(f"ARES report: {m.get('scan_name', '?')}", f"system {m.get('system_name', '?')}  ·  "
                   f"run directory {run.dir.resolve().name}")
    v = m.get("versions") or {}
    lines = [
        ("scan", f"{m.get('scan_name')}  ({m.get('scan_file')})"),
        ("system", f"{m.get('system_name')}  ({m.get('system_file')})"),
        ("scan XML SHA-256", m.get("scan_sha256", "")),
        ("system XML SHA-256", m.get("system_sha256", "")),
        ("started / finished", f"{m.get('started')}  /  {m.get('finished') or '-'}"),
        ("status", f"{run.status}, {len(run.stages)} of {m.get('stages_total') or '?'} stage(s) completed"),
        ("seed / frames override", f"{m.get('seed')} / {m.get('frames_override')}"),
        ("software", "ares " + str(v.get("ares")) + ", python " + str(v.get("python")) + ", "
         + ", ".join(f"{k} {v[k]}" for k in ("numpy", "scipy", "h5py", "lxml") if v.get(k))),
        ("platform", str(v.get("platform", ""))),
    ]
    y = 0.92
    for k, val in lines:
        fig.text(0.06, y, k, fontsize=8.5, weight="bold", va="top")
        fig.text(0.27, y, plots.clip(val, 100), fontsize=8.5, va="top", family="monospace" if "SHA" in k else None)
        y -= 0.018
    if run.attribution:
        fig.text(0.06, y, "data: " + run.attribution, fontsize=9, va="top", style="italic")
        y -= 0.02
    if not run.complete:
        for line in textwrap.wrap(run.incompleteness(), 105)[:4]:
            fig.text(0.06, y, line, fontsize=9, va="top", color="C3", weight="bold")
            y -= 0.017
        y -= 0.004
    for note in run.notes:
        fig.text(0.06, y, note, fontsize=8.5, va="top", color="C3")
        y -= 0.018
    lf = run.limit_failures
    if run.scan_results is not None:
        msg = "limits: all passed" if not lf else f"limits: {len(lf)} failed -- " + "; ".join(lf)
        for line in textwrap.wrap(msg, 115)[:4]:
            fig.text(0.06, y, line, fontsize=9, va="top", color="C3" if lf else "C2")
            y -= 0.017
        y -= 0.003
    na = [f"{k} ({a.get('note') or a.get('status')})" for k, a in run.analyses.items()
          if isinstance(a, dict) and a.get("status") in ("not available", "error")]
    if na:
        fig.text(0.06, y, plots.clip("analyses without results: " + "; ".join(na), 140), fontsize=8, va="top",
                 color="0.35")
        y -= 0.02
    y -= 0.01
    rows = _kf_rows(kf) or [["(no key figures: the run holds no photon-transfer or analysis results)", "", ""]]
    per_page = int((y - 0.05) / (8 * 1.45 / 72 / plots.A4[1])) - 3
    text_table(fig, (0.06, y, 0.9), ["key figure", "value ± SE", "definition / note"], rows[:per_page],
               [0.34, 0.22, 0.44], fontsize=8, title="Key figures", max_chars=[42, 26, 54])
    if len(rows) > per_page:
        fig.text(0.06, 0.03, f"{len(rows) - per_page} more key figure(s) in key_figures.csv", fontsize=8)
    return fig


def ptc_page(g: tables.PtcGroup, rows: list[dict]):
    fig = new_page(f"Photon transfer (analog gain x{g.analog_gain:g})",
                   f"{len(g.stages)} levels; fit range shaded; dark-subtracted signal and temporal variance")
    ax1 = fig.add_axes([0.11, 0.6, 0.83, 0.31])
    notes = plots.ptc_variance(ax1, rows, g.result, "variance vs signal")
    y = 0.545
    if notes:
        fig.text(0.06, y, "excluded levels (numbered in the plot):", fontsize=8, weight="bold", va="top")
        for n in notes[:7]:
            y -= 0.0115
            fig.text(0.06, y, plots.clip(n, 150), fontsize=6.5, va="top")
        if len(notes) > 7:
            fig.text(0.06, y - 0.0115, f"... and {len(notes) - 7} more (see ptc.csv)", fontsize=6.5, va="top")
    ax2 = fig.add_axes([0.11, 0.07, 0.83, 0.34])
    plots.noise_zones(ax2, rows, g.result, "noise vs signal (log-log) with read / shot / PRNU zones")
    return fig


def snr_linearity_page(g: tables.PtcGroup, rows: list[dict]):
    fig = new_page(f"SNR and linearity (analog gain x{g.analog_gain:g})")
    ax1 = fig.add_axes([0.11, 0.58, 0.83, 0.34])
    plots.snr_curve(ax1, g.result, "signal-to-noise ratio")
    ax2 = fig.add_axes([0.11, 0.27, 0.83, 0.23])
    ax3 = fig.add_axes([0.11, 0.07, 0.83, 0.15], sharex=ax2)
    plots.linearity(ax2, ax3, rows, "linearity: signal vs illumination")
    return fig


def _component_table(fig, y: float, stage: dict, part: str, title: str) -> float:
    comps = stage["views"]["full"].get(part) or {}
    rows = []
    for c in tables._ordered(comps):
        e = comps[c]
        n = tables.COMPONENTS.index(c) + 1 if c in tables.COMPONENTS else ""
        rows.append([f"{n} {c}".strip(), tables.fmt_value(e.get("value"), e.get("se"), e.get("unit", "")),
                     tables.COMPONENT_LABELS.get(c, ""), e.get("note", "")])
    return text_table(fig, (0.06, y, 0.9), ["component", "value ± SE", "meaning", "note"], rows,
                      [0.14, 0.3, 0.26, 0.3], fontsize=8.5, title=title, max_chars=[14, 34, 30, 36])


def components_page(run, mid: dict | None, dark: dict | None):
    fig = new_page("Noise components (ANOVA, view 'full')",
                   "13-component model v = o + Cs + Ct + Rs + Rt + Ps + Pt + G·Cg·Rg·Pg·(q + delta); "
                   "variances in DN^2")
    y = 0.92
    if mid is not None:
        s = ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}" for k, v in mid["settings"].items())
        y = _component_table(fig, y, mid, "components", f"mid-level stage {mid['name']} ({mid['scene']})")
        fig.text(0.06, y - 0.003, plots.clip("settings: " + s, 130), fontsize=7.5, va="top", color="0.3")
        y -= 0.04
        if "flat_anova" in mid["views"]["full"]:
            y = _component_table(fig, y, mid, "flat_anova", f"ANOVA of the flat stack itself ({mid['name']})")
            y -= 0.03
    if dark is not None and dark is not mid and y > 0.3:
        _component_table(fig, y, dark, "components", f"dark stage {dark['name']}")
    return fig


def maps_page(run, stage: dict, arrays: dict):
    fig = new_page(f"Signal and noise maps: stage {stage['name']}", "from results.h5 (per-pixel mean and "
                   "temporal variance over the stage's frames)")
    mean = arrays["mean"].astype(float)
    if "dark_mean" in arrays:
        mean = mean - arrays["dark_mean"]
        mtitle = "mean signal (flat - dark)"
    else:
        mtitle = "mean level"
    axes = [fig.add_axes([0.07, 0.53, 0.46, 0.38]), fig.add_axes([0.72, 0.58, 0.25, 0.28]),
            fig.add_axes([0.07, 0.06, 0.46, 0.38]), fig.add_axes([0.72, 0.11, 0.25, 0.28])]
    plots.image_with_hist(fig, axes[0], axes[1], mean, mtitle, "DN")
    if "variance" in arrays:
        plots.image_with_hist(fig, axes[2], axes[3], arrays["variance"], "temporal variance", "DN^2")
    return fig


def dark_page(run, series: dict, kf: dict):
    fig = new_page("Dark signal vs exposure", "dark stages; dark current = slope of the dark mean vs exposure")
    ax1 = fig.add_axes([0.11, 0.56, 0.83, 0.36])
    ax2 = fig.add_axes([0.11, 0.1, 0.83, 0.36])
    from ares.analysis.ptc_fit import line_fit

    for k, (t, s) in enumerate(sorted(series.items(), key=lambda kv: (kv[0] is None, kv[0] or 0))):
        lab = "" if t is None else f"{t:g} C"
        ax1.plot(s["exposure_s"], s["mean_dn"], "o", color=f"C{k}", label=lab or "dark mean")
        ax2.plot(s["exposure_s"], s["var_dn2"], "o", color=f"C{k}", label=(lab + " temporal").strip())
        ax2.plot(s["exposure_s"], s["spatial_var_dn2"], "s", mfc="none", color=f"C{k}", label=(lab + " spatial").strip())
        if np.unique(s["exposure_s"]).size >= 2:
            lf = line_fit(s["exposure_s"], s["mean_dn"])
            xs = np.linspace(0, s["exposure_s"].max(), 20)
            ax1.plot(xs, lf.intercept + lf.slope * xs, "-", color=f"C{k}", lw=0.8,
                     label=f"{lab} fit: {lf.slope:.4g} ± {lf.slope_se:.2g} DN/s".strip())
    ax1.set_xlabel("exposure (s)")
    ax1.set_ylabel("dark mean (DN)")
    ax1.set_title("dark mean vs exposure")
    ax2.set_xlabel("exposure (s)")
    ax2.set_ylabel("variance (DN^2)")
    ax2.set_title("dark temporal and spatial variance vs exposure")
    for a in (ax1, ax2):
        a.grid(alpha=0.3)
        a.legend(fontsize=7, ncol=2)
    return fig


def temperature_page(run, series: dict):
    """Dark current vs temperature with the doubling-temperature fit (>= 3 temperatures)."""
    from ares.analysis.dark_current import doubling_temperature
    from ares.analysis.ptc_fit import line_fit

    T, r, rse = [], [], []
    for t, s in series.items():
        if t is None or np.unique(s["exposure_s"]).size < 2:
            continue
        lf = line_fit(s["exposure_s"], s["mean_dn"])
        T.append(t), r.append(lf.slope), rse.append(lf.slope_se)
    T, r, rse = map(np.array, (T, r, rse))
    fig = new_page("Dark current vs temperature", "slope of the dark mean vs exposure per temperature")
    ax = fig.add_axes([0.11, 0.5, 0.83, 0.4])
    ok = r > 0
    ax.errorbar(T[ok], r[ok], yerr=rse[ok], fmt="o", capsize=2, label="dark current (DN/s)")
    if (~ok).any():
        ax.plot(T[~ok], np.full((~ok).sum(), r[ok].min() if ok.any() else 1e-3), "v", color="C3",
                label="not positive (not shown on log axis)")
    fit = doubling_temperature(T, r, rse if np.all(rse > 0) else None)
    if fit.doubling_c.available:
        ts = np.linspace(T.min(), T.max(), 50)
        ax.plot(ts, fit.value_at_ref.value * 2 ** ((ts - fit.ref_c) / fit.doubling_c.value), "-", color="0.3",
                label=f"doubling temperature {fit.doubling_c:.3g} C")
    ax.set_yscale("log")
    ax.set_xlabel("temperature (C)")
    ax.set_ylabel("dark current (DN/s)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    text_table(fig, (0.08, 0.42, 0.84), ["temperature (C)", "dark current (DN/s)"],
               [[f"{t:g}", tables.fmt_value(v, s)] for t, v, s in zip(T, r, rse)], [0.3, 0.7], fontsize=8.5)
    return fig


def gain_page(groups: list[tables.PtcGroup], run):
    fig = new_page("Gain split: conversion gain and noise vs analog gain")
    ok = [g for g in groups if g.result is not None]
    ag = np.array([g.analog_gain for g in ok])
    K = [g.result.gain_dn_per_e for g in ok]
    rn_dn = [g.result.read_noise_dn for g in ok]
    rn_e = [g.result.read_noise_e for g in ok]
    ax1 = fig.add_axes([0.11, 0.56, 0.83, 0.35])
    ax1.errorbar(ag, [k.value for k in K], yerr=[k.se for k in K], fmt="o-", capsize=2, label="K (DN/e-)")
    if K and K[0].available:
        ax1.plot(ag, K[0].value * ag / ag[0], ":", color="0.4", label="proportional to analog gain")
    ax1.set_xscale("log", base=2)
    ax1.set_yscale("log")
    ax1.set_xticks(ag, [f"x{a:g}" for a in ag])
    ax1.set_xlabel("analog gain")
    ax1.set_ylabel("K (DN/e-)")
    ax1.set_title("system gain vs analog gain")
    ax1.grid(alpha=0.3, which="both")
    ax1.legend()
    ax2 = fig.add_axes([0.11, 0.1, 0.83, 0.35])
    ax2.errorbar(ag, [e.value for e in rn_dn], yerr=[e.se for e in rn_dn], fmt="o-", capsize=2,
                 label="read noise at the output (DN)")
    ax2.errorbar(ag, [e.value for e in rn_e], yerr=[e.se for e in rn_e], fmt="s-", capsize=2,
                 label="input-referred read noise (e-)")
    ax2.set_xscale("log", base=2)
    ax2.set_xticks(ag, [f"x{a:g}" for a in ag])
    ax2.set_xlabel("analog gain")
    ax2.set_ylabel("noise")
    ax2.set_title("read noise at the output (DN) and referred to the input (e-)")
    ax2.grid(alpha=0.3, which="both")
    ax2.legend()
    return fig


def sweep2d_pages(run) -> list:
    """Stages of a 2-D sweep (two coords): grid images of signal, temporal variance and
    the main components over the two swept settings."""
    groups: dict[str, list[dict]] = {}
    for st in run.stages:
        if len(st.get("coords") or []) == 2:
            groups.setdefault(st.get("group") or "sweep", []).append(st)
    figs = []
    for name, sts in groups.items():
        varying = [k for k in sts[0]["settings"] if len({json.dumps(s["settings"].get(k)) for s in sts}) > 1]
        if len(varying) != 2:
            continue
        ky, kx = varying
        xv = sorted({s["settings"][kx] for s in sts})
        yv = sorted({s["settings"][ky] for s in sts})

        def grid(fn):
            a = np.full((len(yv), len(xv)), np.nan)
            for s in sts:
                try:
                    a[yv.index(s["settings"][ky]), xv.index(s["settings"][kx])] = fn(s)
                except (KeyError, TypeError):
                    pass
            return a

        full = lambda s: s["views"]["full"]  # noqa: E731
        has_dark = "dark_level" in full(sts[0])
        panels = [("signal (mean - dark mean)" if has_dark else "mean level", "DN",
                   grid(lambda s: full(s)["level"]["mean_dn"] - full(s).get("dark_level", {}).get("mean_dn", 0.0))),
                  ("temporal variance", "DN^2", grid(lambda s: full(s)["level"]["var_dn2"]))]
        for c in ("G", "Pt", "Ps"):
            if c in full(sts[0]).get("components", {}):
                u = full(sts[0])["components"][c].get("unit", "")
                panels.append((f"{c}: {tables.COMPONENT_LABELS[c]}", u,
                               grid(lambda s, c=c: full(s)["components"][c]["value"])))
        panels = panels[:4]
        fig = new_page(f"2-D sweep '{name}': {ky} x {kx}", f"{len(sts)} stages; values of view 'full'")
        for i, (t, u, a) in enumerate(panels):
            ax = fig.add_axes([0.1 + 0.47 * (i % 2), 0.53 - 0.45 * (i // 2), 0.32, 0.36])
            plots.grid_image(fig, ax, a, xv, yv, kx, ky, t, u)
        figs.append(fig)
    return figs


def frame_means_page(run, stages: list[dict], arrays: dict):
    """Frame means per stage in run order (lag after bright stages, drift, flicker)."""
    fig = new_page("Frame means per stage", "mean of each frame (DN), stages in run order; "
                   "lag shows as excess in the first frames of a dark stage after a bright one")
    ax = fig.add_axes([0.11, 0.5, 0.83, 0.4])
    x0 = 0
    for st in stages:
        fm = arrays.get(st["index"])
        if fm is None or not len(fm):
            continue
        xs = np.arange(x0, x0 + len(fm))
        ax.plot(xs, fm, "o-", ms=3, label=st["name"])
        x0 += len(fm) + 1
    ax.set_yscale("log")
    ax.set_xlabel("frame (stages in run order)")
    ax.set_ylabel("frame mean (DN)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=3, loc="best")
    rows = []
    for st in stages:
        fm = arrays.get(st["index"])
        if fm is None or len(fm) < 2:
            continue
        rows.append([st["name"], st["scene"], f"{fm[0]:.5g}", f"{np.mean(fm[1:]):.5g}", f"{fm[0] - np.mean(fm[1:]):.4g}"])
    text_table(fig, (0.08, 0.42, 0.84), ["stage", "scene", "first frame (DN)", "mean of the rest (DN)",
                                          "first - rest (DN)"], rows[:30], [0.22, 0.12, 0.22, 0.24, 0.2], fontsize=8)
    return fig


def analysis_pages(run) -> list:
    """One page per scan-level analysis other than ptc/decomposition: its status, its
    estimates as a table, and any equal-length number lists as curves."""
    figs = []
    for name, a in run.analyses.items():
        if name in ("ptc", "decomposition") or not isinstance(a, dict) or \
                a.get("status") in ("not available", "error"):
            continue  # listed on the title page
        fig = new_page(f"Scan-level analysis: {name}", "from scan_results.json")
        y = 0.92
        if a.get("status") or a.get("note"):
            fig.text(0.06, y, plots.clip(f"status: {a.get('status', 'ok')}  {a.get('note', '')}", 130), fontsize=9,
                     va="top", color="C3" if a.get("status") in ("not available", "error") else "k")
            y -= 0.03
        ests = tables._flat_estimates(a)
        lists = {k: np.asarray(v, float) for k, v in a.items() if isinstance(v, list) and v
                 and all(isinstance(x, (int, float)) or x is None for x in v)}
        scal = [(k, v) for k, v in a.items() if isinstance(v, (int, float, str)) and k not in ("status", "note")]
        rows = [[k, tables.fmt_value(e.get("value"), e.get("se"), e.get("unit", "")), e.get("note", "")]
                for k, e in ests] + [[k, str(v), ""] for k, v in scal]
        if rows:
            y = text_table(fig, (0.06, y, 0.9), ["quantity", "value ± SE", "note"], rows[:40], [0.3, 0.3, 0.4],
                           fontsize=8, max_chars=[36, 34, 50]) - 0.03
        if len(lists) >= 2 and y > 0.25:
            keys = list(lists)
            xk = keys[0]
            ax = fig.add_axes([0.11, 0.07, 0.83, min(0.35, y - 0.12)])
            for k in keys[1:]:
                if lists[k].shape == lists[xk].shape:
                    ax.plot(lists[xk], lists[k], "o-", ms=3, label=k)
            ax.set_xlabel(xk)
            ax.grid(alpha=0.3)
            ax.legend()
        figs.append(fig)
    return figs


def stages_pages(run) -> list:
    keys = list(dict.fromkeys(k for st in run.stages for k in st["settings"]))
    vary = [k for k in keys if len({json.dumps(st["settings"].get(k)) for st in run.stages}) > 1]
    const = [k for k in keys if k not in vary]

    def fmt(k, v):
        return f"{k.removeprefix('reg:')}={v:.5g}" if isinstance(v, (int, float)) else f"{k.removeprefix('reg:')}={v}"

    rows = []
    for st in run.stages:
        full = st["views"]["full"]
        dm = full.get("dark_level", {}).get("mean_dn")
        rows.append([str(st["index"]), st["name"], st["scene"], f"{st['frames']}/{st.get('dark_frames', 0)}",
                     f"{full['level']['mean_dn']:.5g}", "" if dm is None else f"{dm:.5g}",
                     tables.fmt_value(full["level"].get("var_dn2")),
                     ", ".join(fmt(k, st["settings"][k]) for k in vary if k in st["settings"])])
    same = ", ".join(fmt(k, run.stages[0]["settings"][k]) for k in const if k in run.stages[0]["settings"]) \
        if run.stages else ""
    figs = []
    per = 55
    for k in range(0, max(len(rows), 1), per):
        fig = new_page("Stages", plots.clip(f"{len(rows)} completed stage(s), view 'full'"
                                            + ("" if run.complete else " (incomplete run)")
                                            + (f"; all stages: {same}" if same else ""), 130))
        text_table(fig, (0.04, 0.93, 0.93), ["#", "stage", "scene", "frames/dark", "mean (DN)", "dark (DN)",
                                             "var (DN^2)", "settings that vary"],
                   rows[k:k + per] or [["", "(no stages)"]],
                   [0.04, 0.13, 0.06, 0.09, 0.1, 0.1, 0.1, 0.38], fontsize=7,
                   max_chars=[5, 18, 6, 10, 11, 11, 11, 60])
        figs.append(fig)
    return figs


def build_pages(run, groups=None, kf=None) -> list[tuple[str, object]]:
    groups = tables.ptc_groups(run) if groups is None else groups
    kf = tables.compute_key_figures(run, groups) if kf is None else kf
    pages = [("title", title_page(run, kf))]
    ptc_ok = [g for g in groups if g.result is not None]
    for g in ptc_ok:
        rows = tables.ptc_rows([g])
        pages.append((f"ptc x{g.analog_gain:g}", ptc_page(g, rows)))
        pages.append((f"snr x{g.analog_gain:g}", snr_linearity_page(g, rows)))
        if len(ptc_ok) > 2:  # many gains: the first gain in full, the rest on the gain page
            break
    if len(ptc_ok) >= 2:
        pages.append(("gain split", gain_page(ptc_ok, run)))
    mid, dark = tables.mid_stage(run), tables.dark_stage(run)
    if mid is not None:
        pages.append(("components", components_page(run, mid, dark)))
    for st in [s for s in (mid, dark) if s is not None]:
        arr = run.arrays(st["index"])
        if "mean" in arr:
            pages.append((f"maps {st['name']}", maps_page(run, st, arr)))
        if st is dark:
            break
    series = tables.dark_series(run)
    if any(np.unique(s["exposure_s"]).size >= 2 for s in series.values()):
        pages.append(("dark", dark_page(run, series, kf)))
        temps = [t for t, s in series.items() if t is not None and np.unique(s["exposure_s"]).size >= 2]
        if len(temps) >= 3:
            pages.append(("temperature", temperature_page(run, series)))
    for fig in sweep2d_pages(run):
        pages.append(("sweep 2d", fig))
    seq = [s for s in run.stages if not s.get("coords")]
    if len(seq) >= 2 and any(a.get("scene") == "flat" and b.get("scene") == "dark" for a, b in zip(seq, seq[1:])):
        fms = {s["index"]: run.arrays(s["index"]).get("frame_means") for s in seq}
        if any(v is not None for v in fms.values()):
            pages.append(("frame means", frame_means_page(run, seq, fms)))
    for fig in analysis_pages(run):
        pages.append(("analysis", fig))
    pages += [("stages", f) for f in stages_pages(run)]
    for i, (_, fig) in enumerate(pages):
        fig.text(0.5, 0.012, f"{run.meta.get('scan_name', '')} · {run.dir.resolve().name} · page {i + 1} of "
                 f"{len(pages)}" + (f" · {run.attribution}" if run.attribution else ""), ha="center", fontsize=7,
                 color="0.4")
    return pages


def write_pdf(run, path: str | Path, groups=None, kf=None) -> list[str]:
    """Write the report to ``path``; returns the page titles."""
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with matplotlib.rc_context(plots.RC):
        pages = build_pages(run, groups, kf)
        with PdfPages(tmp, metadata={"Title": f"ARES report {run.meta.get('scan_name', '')}",
                                     "Creator": "ares report"}) as pdf:
            for _, fig in pages:
                pdf.savefig(fig)
    tmp.replace(path)
    return [t for t, _ in pages]
