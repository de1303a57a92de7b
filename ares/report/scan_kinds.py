"""Report pages for the other scan kinds: dark signal vs exposure and temperature, gain
split, 2-D sweeps, frame means and lag, defects, ADC INL/DNL -- and a generic page for
any other scan-level analysis in ``scan_results.json``. Each page is drawn from the stage
results and the runner's scan-level results; nothing is re-measured."""

from __future__ import annotations

import json
from functools import partial

import numpy as np

from ares.report import page_tables, plots, tables
from ares.report.plots import new_page, text_table
from ares.report.defect_pages import adc_page, defect_map_page, defects_page
from ares.report.page_tables import _table, analysis_rows, available
from ares.report import series_tables

HANDLED = ("mtf", "photon_counting", "spectral_qe", "ptc", "decomposition", "dark_current", "temperature", "gain_split", "lag", "defects", "adc_linearity",
           "emva4", "dark_temperature", "rtn", "fe55")


# ------------------------------------------------------------------ dark / temperature

def dark_page(run, series: dict):
    from ares.analysis.ptc.dark_current import dark_current
    from ares.analysis.ptc.fit import line_fit

    fig = new_page("Dark signal vs exposure", "dark stages; dark current = slope of the dark mean vs exposure")
    dc = available(run, "dark_current")
    ax1 = fig.add_axes([0.11, 0.64, 0.83, 0.27])
    # temporal and spatial variance on axes of their own: the spatial (DSNU) variance is
    # orders above the temporal one, whose slope (the dark shot noise) would be flat beside it
    y2 = 0.3 if dc else 0.1
    ax2 = fig.add_axes([0.11, y2, 0.37, 0.25])
    ax3 = fig.add_axes([0.59, y2, 0.35, 0.25])
    for k, (t, s) in enumerate(sorted(series.items(), key=lambda kv: (kv[0] is None, kv[0] or 0))):
        lab = "" if t is None else f"{t:g} C"
        fit = np.unique(s["exposure_s"]).size >= 2  # then the fit's legend entry names the colour
        ax1.plot(s["exposure_s"], s["mean_dn"], "o", color=f"C{k}", label=None if fit else lab or "dark mean")
        ax2.plot(s["exposure_s"], s["var_dn2"], "o", color=f"C{k}", label=None if fit else lab or "temporal")
        ax3.plot(s["exposure_s"], s["spatial_var_dn2"], "s", mfc="none", color=f"C{k}", label=lab or "spatial")
        if fit:  # the analysis's own slopes and SEs (K = 1: DN/s and DN^2/s), as the table beside them
            d = dark_current(s["exposure_s"], s["mean_dn"], 1.0, s["var_dn2"], frame_means=s.get("frame_means"),
                             frame_times=s.get("frame_times"))
            lf = line_fit(s["exposure_s"], s["mean_dn"])
            lv = line_fit(s["exposure_s"], s["var_dn2"])
            m_txt = (page_tables.fmt_value(d.rate_dn_per_s.value, d.rate_dn_per_s.se, 'DN/s')
                     if d.rate_dn_per_s.available else f"n/a ({d.rate_dn_per_s.note})")
            v = d.rate_from_variance_e_per_s
            v_txt = page_tables.fmt_value(v.value, v.se, 'DN^2/s') if v.available else f"n/a ({v.note})"
            xs = np.linspace(0, s["exposure_s"].max(), 20)
            ax1.plot(xs, lf.intercept + lf.slope * xs, "-", color=f"C{k}", lw=0.8, label=f"{lab} fit: {m_txt}".strip())
            ax2.plot(xs, lv.intercept + lv.slope * xs, "-", color=f"C{k}", lw=0.8, label=f"{lab} slope {v_txt}".strip())
    ax1.set_xlabel("exposure (s)")
    ax1.set_ylabel("dark mean (DN)")
    ax1.set_title("dark mean vs exposure")
    ax2.set_xlabel("exposure (s)")
    ax2.set_ylabel("temporal variance (DN^2)")
    ax2.set_title("temporal variance vs exposure", fontsize=9)
    ax3.set_xlabel("exposure (s)")
    ax3.set_ylabel("spatial variance (DN^2)")
    ax3.set_title("dark spatial variance vs exposure", fontsize=9)
    for a in (ax1, ax2, ax3):
        a.grid(alpha=0.3)
        a.legend(fontsize=7 if a is ax1 else 6, ncol=2 if a is ax1 else 1, loc="upper left", framealpha=0.6)
    if dc:
        rows = [r for r in analysis_rows(dc, skip_na=True) if not r[0].endswith("temperature_c")]
        _table(fig, 0.22, rows, "dark_current analysis (scan_results.json)", n=12)
    return fig


def temperature_page(run, series: dict):
    """Dark current vs temperature with the doubling-temperature fit (>= 3 temperatures)."""
    from ares.analysis.ptc.dark_current import dark_current, doubling_temperature

    T, r, rse = [], [], []
    for t, s in sorted((kv for kv in series.items() if kv[0] is not None), key=lambda kv: kv[0]):
        # the analysis's own dark current per temperature (DN/s: K = 1), its SE on the frames' scatter
        e = dark_current(s["exposure_s"], s["mean_dn"], 1.0, frame_means=s.get("frame_means"),
                         frame_times=s.get("frame_times")).rate_dn_per_s
        if e.available:
            T.append(t), r.append(e.value), rse.append(e.se)
    T, r, rse = map(np.array, (T, r, rse))
    fig = new_page("Dark current vs temperature", "slope of the dark mean vs exposure per temperature; "
                   "X_T = X_ref * 2^((T - ref)/Td)")
    ax = fig.add_axes([0.11, 0.52, 0.83, 0.38])
    ok = r > 0
    lower = np.where(rse[ok] < r[ok], rse[ok], 0.0)  # no lower bar through zero on a log axis
    ax.errorbar(T[ok], r[ok], yerr=[lower, rse[ok]], fmt="o", capsize=2, label="dark current (DN/s)")
    stored = available(run, "temperature")
    fit = doubling_temperature(T, r, rse if np.all(rse > 0) else None)
    if fit.doubling_c.available:
        ts = np.linspace(T.min(), T.max(), 50)
        ax.plot(ts, fit.value_at_ref.value * 2 ** ((ts - fit.ref_c) / fit.doubling_c.value), "-", color="0.3",
                label=f"doubling temperature {fit.doubling_c.text()}")
    ax.set_yscale("log")
    ax.set_xlabel("temperature (C)")
    ax.set_ylabel("dark current (DN/s)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    dc = available(run, "dark_current") or {}
    by_t = dc.get("by_temperature") or {}
    e_s = [by_t.get(f"{t:g}C", {}).get("rate_e_per_s") or {} for t in T]  # beside DN/s: e-/s, or why not
    y = text_table(fig, (0.08, 0.44, 0.84), ["temperature (C)", "dark current (DN/s)", "dark current (e-/s)"],
                   [[f"{t:g}", page_tables.fmt_value(v, s), page_tables.fmt_value(e.get("value"), e.get("se"))]
                    for t, v, s, e in zip(T, r, rse, e_s)], [0.2, 0.4, 0.4], fontsize=8.5)
    if dc.get("gain_from"):
        fig.text(0.08, y - 0.005, f"gain for e-/s: {dc['gain_from']}", fontsize=8, va="top")
        y -= 0.02
    if stored:
        _table(fig, y - 0.02, analysis_rows(stored), "temperature analysis (scan_results.json)")
    return fig


# ------------------------------------------------------------------ gain split

def gain_page(run, groups: list):
    fig = new_page("Gain split: conversion gain and noise vs analog gain")
    ok = [g for g in groups if g.result is not None]
    ag = np.array([g.analog_gain for g in ok])
    K = [g.result.gain_dn_per_e for g in ok]
    rn_dn = [g.result.read_noise_dn for g in ok]
    rn_e = [g.result.read_noise_e for g in ok]
    gs = available(run, "gain_split")
    ax1 = fig.add_axes([0.11, 0.66, 0.83, 0.26])
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
    ax2 = fig.add_axes([0.11, 0.3, 0.78, 0.26])
    ax2e = ax2.twinx()  # the two noises in their own units: DN at the output (left), e- at the input (right)
    ax2.errorbar(ag, [e.value for e in rn_dn], yerr=[e.se for e in rn_dn], fmt="o", capsize=2, color="C0",
                 label="read noise at the output (DN, left)")
    ax2e.errorbar(ag, [e.value for e in rn_e], yerr=[e.se for e in rn_e], fmt="s", capsize=2, color="C1",
                  label="input-referred read noise (e-, right)")
    if gs:
        pix, chain = tables.est(gs.get("pixel_noise_e")), tables.est(gs.get("chain_noise_dn"))
        kv = np.array([k.value for k in K])
        if pix.available and chain.available:
            ax2.plot(ag, np.sqrt((pix.value * kv) ** 2 + chain.value**2), "-", color="C0", lw=0.8,
                     label=f"model: pixel {pix.value:.3g} e- x K (+) chain {chain.value:.3g} DN")
            ax2e.plot(ag, np.sqrt(pix.value**2 + (chain.value / kv) ** 2), "-", color="C1", lw=0.8,
                      label="model, input-referred")
    ax2.set_xscale("log", base=2)
    ax2.set_xticks(ag, [f"x{a:g}" for a in ag])
    ax2.set_xlabel("analog gain")
    ax2.set_ylabel("read noise at the output (DN rms)", color="C0")
    ax2e.set_ylabel("input-referred read noise (e- rms)", color="C1")
    ax2.set_title("read noise at the output (DN) and referred to the input (e-)")
    ax2.grid(alpha=0.3, which="both")
    h1, l1 = ax2.get_legend_handles_labels()
    h2, l2 = ax2e.get_legend_handles_labels()
    ax2.legend(h1 + h2, l1 + l2, fontsize=7)
    y = text_table(fig, (0.08, 0.21, 0.84), ["analog gain", "K (DN/e-)", "read noise (DN)", "read noise (e-)"],
                   [[f"x{g.analog_gain:g}", k.text(with_unit=False), a.text(with_unit=False), b.text(with_unit=False)]
                    for g, k, a, b in zip(ok, K, rn_dn, rn_e)], [0.2, 0.27, 0.27, 0.26], fontsize=8)
    if gs:
        rows = [r for r in analysis_rows(gs) if r[0] not in ("analog_gains", "gain_dn_per_e")]
        _table(fig, y - 0.01, rows, "", n=6)
    return fig


# ------------------------------------------------------------------ 2-D sweeps

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
                    v = fn(s)
                    a[yv.index(s["settings"][ky]), xv.index(s["settings"][kx])] = np.nan if v is None else v
                except (KeyError, TypeError):
                    pass
            return a

        def full(s):
            return s["views"]["full"]

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
        cycles = ((available(run, "lag") or {}).get("cycles") or {})
        if any(s["name"] in cycles for s in sts):  # dark="after": the lag of every point (the window's lag map)
            panels.append(("image lag (blank: not resolved from 0)", "%",  # (a limit is no value to colour)
                           grid(lambda s: _ok_value(cycles[s["name"]].get("lag_pct")))))
        fig = new_page(f"2-D sweep '{name}': {ky.removeprefix('reg:')} x {kx.removeprefix('reg:')}",
                       f"{len(sts)} stages; values of view 'full'")
        units = run.setting_units

        def label(k):
            return k.removeprefix("reg:") + (f" ({units[k]})" if units.get(k) else "")

        rows = (len(panels) + 1) // 2
        h = 0.86 / rows  # 2 columns; the colour bar and its label beside each panel, clear of the next
        for i, (t, u, a) in enumerate(panels):
            ax = fig.add_axes([0.09 + 0.48 * (i % 2), 0.92 - h * (i // 2 + 1) + 0.07, 0.28, h - 0.11])
            plots.grid_image(fig, ax, a, xv, yv, label(kx), label(ky), t, u)
        figs.append(fig)
    return figs


# ------------------------------------------------------------------ frame means, lag

def _ok_value(e: dict | None):
    """A figure's value where its verdict is "ok" (None for a limit or not available)."""
    return e.get("value") if e and e.get("verdict") == "ok" else None


def frame_means_page(run, stages: list[dict], arrays: dict):
    """Frame means per stage in run order (lag after bright stages, drift, flicker)."""
    fig = new_page("Frame means per stage and image lag", "mean of each frame (DN), stages in run order; "
                   "lag shows as excess in the first frames of a dark stage after a bright one")
    ax = fig.add_axes([0.11, 0.6, 0.83, 0.31])
    x0 = 0
    for st in stages:
        fm = arrays.get(st["index"])
        if fm is None or not len(fm):
            continue
        ax.plot(np.arange(x0, x0 + len(fm)), fm, "o-", ms=3, label=st["name"])
        x0 += len(fm) + 1
    ax.set_yscale("log")
    ax.set_xlabel("frame (stages in run order)")
    ax.set_ylabel("frame mean (DN)")
    ax.grid(alpha=0.3)
    # the legend above the axes: bright and dark stages fill the plot from top to bottom
    ax.legend(fontsize=7, ncol=min(6, max(1, len(stages))), loc="lower left", bbox_to_anchor=(0, 1.01),
              frameon=False)
    rows = []
    for st in stages:
        fm = arrays.get(st["index"])
        if fm is None or len(fm) < 2:
            continue
        rows.append([st["name"], st["scene"], f"{fm[0]:.5g}", f"{np.mean(fm[1:]):.5g}",
                     f"{fm[0] - np.mean(fm[1:]):.4g}"])
    y = text_table(fig, (0.08, 0.52, 0.84), ["stage", "scene", "first frame (DN)", "mean of the rest (DN)",
                                              "first - rest (DN)"], rows[:20], [0.22, 0.12, 0.22, 0.24, 0.2],
                   fontsize=8)
    lag = available(run, "lag")
    if lag and isinstance(lag.get("cycles"), dict):
        crow = []
        cyc = lag["cycles"]
        vary = {k for c in cyc.values() for k in (c.get("settings") or {})
                if len({json.dumps((c2.get("settings") or {}).get(k)) for c2 in cyc.values()}) > 1}
        for bright, c in cyc.items():
            e = c.get("lag_pct") or {}
            s = ", ".join(f"{k.removeprefix('reg:')}={v:g}" for k, v in (c.get("settings") or {}).items()
                          if isinstance(v, (int, float)) and k in vary)
            crow.append([bright, str(c.get("dark_stage", "")),
                         page_tables.fmt_value(e.get("value"), e.get("se"), "%", e.get("verdict", "")),
                         f"{c.get('bright_signal_dn', float('nan')):.5g}", s])
        text_table(fig, (0.08, y - 0.03, 0.84), ["bright stage", "dark stage", "lag (%)", "bright signal (DN)",
                                                  "settings that vary"], crow[:20], [0.16, 0.14, 0.2, 0.18, 0.32],
                   fontsize=8, title="image lag (scan_results.json)", max_chars=[18, 16, 22, 14, 40])
    return fig


def lag_page(run, stages: list[dict], arrays: dict, lag: dict):
    """What a datasheet reader looks for in image lag: each dark stack's excess over its
    settled level, frame by frame on linear axes (the 0.2-0.7 DN that a log axis of frame
    means hides), and the lag against the setting the scan varies, with its SE."""
    fig = new_page("Image lag", "dark frames after each bright stack minus their settled level; "
                   "lag = first-frame excess / bright signal")
    cyc = lag["cycles"]
    by_name = {st["name"]: st for st in stages}
    vary = sorted({k for c in cyc.values() for k in (c.get("settings") or {})
                   if len({json.dumps((c2.get("settings") or {}).get(k)) for c2 in cyc.values()}) > 1})
    ax = fig.add_axes([0.11, 0.56, 0.83, 0.34])
    for k, (bright, c) in enumerate(cyc.items()):
        dark = by_name.get(c.get("dark_stage"))
        fm = arrays.get(dark["index"]) if dark is not None else None
        if fm is None or len(fm) < 3:
            continue
        fm = np.asarray(fm, float)
        settled = float(np.mean(fm[2:])) if len(fm) > 2 else float(fm[-1])
        label = ", ".join(f"{v.removeprefix('reg:')}={c['settings'][v]:g}" for v in vary
                          if isinstance((c.get("settings") or {}).get(v), (int, float))) or bright
        ax.plot(np.arange(1, len(fm) + 1), fm - settled, "o-", ms=3, color=f"C{k % 10}", label=label)
    ax.axhline(0, color="0.4", lw=0.8)
    ax.set_xlabel("dark frame after the bright stack")
    ax.set_ylabel("frame mean - settled dark (DN)")
    ax.set_title("lag vs frame")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=3)
    num = [v for v in vary if all(isinstance((c.get("settings") or {}).get(v), (int, float)) for c in cyc.values())]
    if num:
        key = num[0]
        xs = [c["settings"][key] for c in cyc.values()]
        es_ = [c.get("lag_pct") or {} for c in cyc.values()]
        ok = [i for i, e in enumerate(es_) if e.get("verdict") == "ok"]
        ax2 = fig.add_axes([0.11, 0.12, 0.83, 0.32])
        ax2.errorbar([xs[i] for i in ok], [es_[i]["value"] for i in ok], yerr=[es_[i].get("se") or 0 for i in ok],
                     fmt="o-", capsize=3, label="image lag ± 1 SE")
        for which, mark in (("upper limit", "v"), ("lower limit", "^")):  # not resolved from 0: the bound only
            lim = [i for i, e in enumerate(es_) if e.get("verdict") == which]
            if lim:
                ax2.plot([xs[i] for i in lim], [es_[i]["value"] for i in lim], mark, color="0.35", ls="none",
                         label=f"{which} (not resolved from 0: value {'+' if mark == 'v' else '-'} 3 SE)")
        ax2.legend(fontsize=7)
        ax2.axhline(0, color="0.4", lw=0.8)
        unit = run.setting_units.get(key, "")
        ax2.set_xlabel(f"{key.removeprefix('reg:')}" + (f" ({unit})" if unit else ""))
        ax2.set_ylabel("image lag (% of the bright signal)")
        ax2.set_title(f"lag vs {key.removeprefix('reg:')} (error bars: 1 SE)")
        ax2.grid(alpha=0.3)
    return fig


# ------------------------------------------------------------------ defects


# ------------------------------------------------------------------ ADC INL/DNL


# ------------------------------------------------------------------ anything else

def generic_page(name: str, a: dict):
    from ares.labels import analysis_title

    fig = new_page(f"Scan-level analysis: {analysis_title(name)}", "from scan_results.json")
    y = 0.92
    rows = analysis_rows(a)
    y = _table(fig, y, rows, n=50)
    lists = {k: np.asarray([np.nan if x is None else x for x in v], float) for k, v in a.items()
             if isinstance(v, list) and len(v) > 2 and all(isinstance(x, (int, float)) or x is None for x in v)}
    if lists and y > 0.25:
        ax = fig.add_axes([0.11, 0.07, 0.83, min(0.35, y - 0.12)])
        for k, v in lists.items():
            ax.plot(np.arange(v.size), v, "o-", ms=3, label=k)
        ax.set_xlabel("index")
        ax.grid(alpha=0.3)
        ax.legend()
    return fig


def pages(run, groups: list) -> list[tuple[str, object]]:
    """(title, maker) pairs as ``pdf.page_plan`` takes them."""
    out = []
    ptc_ok = [g for g in groups if g.result is not None and g.is_curve]
    if len(ptc_ok) >= 2:
        out.append(("gain split", partial(gain_page, run, ptc_ok)))
    series = series_tables.dark_series(run)
    if any(np.unique(s["exposure_s"]).size >= 2 for s in series.values()):
        out.append(("dark", partial(dark_page, run, series)))
        temps = [t for t, s in series.items() if t is not None and np.unique(s["exposure_s"]).size >= 2]
        if len(temps) >= 3:
            out.append(("temperature", partial(temperature_page, run, series)))
    out += [("sweep 2d", f) for f in sweep2d_pages(run)]
    seq = [s for s in run.stages if not s.get("coords")]
    if len(seq) >= 2 and any(a.get("scene") == "flat" and b.get("scene") == "dark" for a, b in zip(seq, seq[1:])):
        fms = {s["index"]: (s["views"]["full"]["level"].get("frame_means")
                            or run.arrays(s["index"]).get("frame_means")) for s in seq}
        fms = {k: np.asarray(v, float) for k, v in fms.items() if v is not None}
        if fms:
            out.append(("frame means", partial(frame_means_page, run, seq, fms)))
            lag = available(run, "lag")
            if lag and isinstance(lag.get("cycles"), dict) and lag["cycles"]:
                out.append(("lag", partial(lag_page, run, seq, fms, lag)))
    d = available(run, "adc_linearity")
    if d:
        out.append(("adc", partial(adc_page, run, d)))
    d = available(run, "defects")
    if d:
        out.append(("defects", partial(defects_page, run, d)))
        if d.get("shape"):
            out.append(("defect map", partial(defect_map_page, run, d)))
    d = available(run, "mtf")
    if d:  # the slanted-edge MTF, one page per stage (ares.report.mtf_page)
        from ares.report.mtf_page import mtf_page

        for stage, s in d["stages"].items():
            out.append((f"mtf {stage}", partial(mtf_page, s["channels"], f"Slanted-edge MTF: stage {stage}",
                                                f"ISO 12233 e-SFR of the {'dark-subtracted ' if s['dark_subtracted'] else ''}"
                                                f"mean of {s['frames']} frames")))
    d = available(run, "photon_counting")
    if d:  # the photon-counting histogram, one page per stage (ares.report.photon_counting_page)
        from ares.report.photon_counting_page import photon_counting_page

        out += [(f"photon counting {k}", partial(photon_counting_page, k, v)) for k, v in d["stages"].items()]
    d = available(run, "spectral_qe")
    if d:  # QE(lambda) with error bars (ares.report.spectral_qe_page)
        from ares.report.spectral_qe_page import spectral_qe_page

        out.append(("spectral QE", partial(spectral_qe_page, d)))
    d = available(run, "fe55")
    if d:  # the Fe-55 line fit, one page per stage (ares.report.fe55_page)
        from ares.report.fe55_page import fe55_page

        out += [(f"fe55 {k}", partial(fe55_page, k, v)) for k, v in d["stages"].items() if "kalpha_dn" in v]
    for name, maker in (("dark_temperature", "dark_temperature_page"), ("rtn", "rtn_page")):
        d = available(run, name)
        if d:  # (ares.report.lowlight_pages)
            from ares.report import lowlight_pages

            fn = getattr(lowlight_pages, maker)
            out.append((name.replace("_", " "), partial(fn, run, d) if name == "dark_temperature" else partial(fn, d)))
    for name, a in run.analyses.items():
        if name not in HANDLED and available(run, name):
            out.append((f"analysis {name}", partial(generic_page, name, a)))
    return out
