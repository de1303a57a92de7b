"""The PDF report of a run directory (matplotlib PdfPages, A4 portrait).

Pages, each only when the run has the data: title + key figures; photon transfer
(variance vs signal, log-log noise zones) per analog gain; SNR and linearity; the 13
components of the mid-level stage and of the dark stage; signal/noise maps with
histograms; dark signal vs exposure (and temperature); gain vs analog gain; 2-D sweep
maps; frame means per stage (lag, drift); every other scan-level analysis; the stage
list. ``pdf_parts.write_pdf`` writes them and returns the page titles in order.
"""

from __future__ import annotations

import json
import textwrap
from functools import partial
from pathlib import Path

import matplotlib
import numpy as np

from ares.hardware import link_stats
from ares.report import key_figure_pages, page_tables, plots, scan_kinds, tables
from ares.report.plots import new_page, text_table


def title_page(run, kf: dict, chunks: list | None = None) -> "plots.Figure":
    """The title page: the run's identity and state, then the key figures that fit (the
    first of ``chunks``, ``key_figure_pages.split``; the rest go on continuation pages)."""
    m = run.meta
    fig = new_page(f"ARES report: {m.get('scan_name', '?')}", f"system {m.get('system_name', '?')}  ·  "
                   f"run directory {run.dir.resolve().name}")
    y = _title_head(fig, run)
    chunks = key_figure_pages.split(key_figure_pages.rows_of(kf), y) if chunks is None else chunks
    key_figure_pages.draw(fig, y, chunks[0], "Key figures", sum(len(c) for c in chunks[1:]))
    return fig


def _title_head(fig, run) -> float:
    """Everything above the key figures drawn on ``fig``; the y below it."""
    m = run.meta
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
        *link_stats.device_lines(m), *link_stats.link_lines(m),  # IDs and link statistics (real benches)
    ]
    y = 0.92
    desc = run.description()
    if desc:
        for line in textwrap.wrap(desc, 110)[:3]:
            fig.text(0.06, y, line, fontsize=9, va="top", style="italic")
            y -= 0.017
        y -= 0.006
    for k, val in lines:
        fig.text(0.06, y, k, fontsize=8.5, weight="bold", va="top")
        mono = "SHA" in k
        # a long value (a device's identity, the software line) wraps within the page, never cut at its edge
        for part in (textwrap.wrap(str(val), 64 if mono else 88) or [""])[:3]:
            fig.text(0.27, y, part, fontsize=8.5, va="top", family="monospace" if mono else None)
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
    # (the headline K's statement beside Eq. 50, k_statement_of, is the K key figure's note: once, beside K)
    lim = run.limits
    if run.scan_results is not None or lim["state"] == "not checked":
        color = {"failed": "C3", "passed": "C2"}.get(lim["state"], "0.35")  # green only for limits checked and passed
        for line in textwrap.wrap(lim["text"], 115)[:4]:
            fig.text(0.06, y, line, fontsize=9, va="top", color=color)
            y -= 0.017
        y -= 0.003
    na = [f"{k} ({a.get('note') or a.get('status')})" for k, a in run.analyses.items()
          if isinstance(a, dict) and a.get("status") in ("not available", "error")]
    if na:
        fig.text(0.06, y, plots.clip("analyses without results: " + "; ".join(na), 140), fontsize=8, va="top",
                 color="0.35")
        y -= 0.02
    return y - 0.01


def key_figure_chunks(run, kf: dict) -> list:
    """The key-figure rows per page (title page first), from the room the title page leaves."""
    return key_figure_pages.split(key_figure_pages.rows_of(kf), _title_head(plots.Figure(figsize=plots.A4), run))


def ptc_page(g: tables.PtcGroup, rows: list[dict]):
    status = [r["status"] for r in rows]
    fig = new_page(f"Photon transfer (analog gain x{g.analog_gain:g})",
                   f"{len(g.stages)} levels ({status.count('fit')} fitted, {status.count('excluded')} excluded); "
                   "fit range shaded; dark-subtracted signal and temporal variance")
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
    if g.mismatch():
        fig.text(0.5, 0.935, g.mismatch(), ha="center", fontsize=7, color="C3")
    return fig


def snr_linearity_page(g: tables.PtcGroup, rows: list[dict]):
    fig = new_page(f"SNR and linearity (analog gain x{g.analog_gain:g})")
    ax1 = fig.add_axes([0.11, 0.58, 0.83, 0.34])
    plots.snr_curve(ax1, g.result, "signal-to-noise ratio")
    ax2 = fig.add_axes([0.11, 0.29, 0.83, 0.21])
    ax3 = fig.add_axes([0.11, 0.07, 0.83, 0.15])  # its own x axis: log for a log-spaced sweep
    plots.linearity(ax2, ax3, rows, "linearity: signal vs illumination")
    return fig


EDGE_NOTE = "(of an edge image: no PRNU)"


def _component_table(fig, y: float, stage: dict, part: str, title: str, edge: bool = False) -> float:
    """A stage's components of ``part``; with a defect mask (``components_masked``, the
    figures the terminal and the key figures state) those are the values, and the
    all-pixel estimate stands beside each under its own heading."""
    full = stage["views"]["full"]
    masked = part == "components" and bool(full.get("components_masked"))
    comps = (full.get("components_masked") if masked else full.get(part)) or {}
    rows = []
    for c in tables._ordered(comps):
        e = comps[c]
        n = tables.COMPONENTS.index(c) + 1 if c in tables.COMPONENTS else ""
        spread = edge and c in tables.GAIN_SPREADS  # a gain spread of an edge image is the edge, not the pixels
        row = [f"{n} {c}".strip(), tables.component_text(c, e)]
        if masked:
            row.append(tables.component_text(c, (full.get("components") or {}).get(c) or {}))
        alone = part == "components" and stage.get("scene") == "flat" and "G" not in comps  # no matched dark
        rows.append(row + [tables.component_label(c, "flat_anova" if alone else part),
                           EDGE_NOTE if spread else e.get("note", "")])
    if masked:
        dm = stage.get("defect_mask") or {}  # (its source: ares.scan.mask_complete)
        kind = ("dark classes only, provisional" if dm.get("provisional")
                else "dark and flat classes" if "flat stage" in str(dm.get("mask_source", "")) else "")
        title += f": {full.get('masked_pixels', 0)} defect pixels excluded" + (f" (mask: {kind})" if kind else "")
    if not any(r[-1] for r in rows):  # no notes: the meaning gets their room ("(read + shot)" was cut)
        rows = [r[:-1] for r in rows]
        if masked:
            return text_table(fig, (0.06, y, 0.9), ["component", "defects excluded", "all pixels", "meaning"],
                              rows, [0.12, 0.23, 0.23, 0.42], fontsize=8, title=title, max_chars=[12, 25, 25, 50],
                              wrap=True)
        return text_table(fig, (0.06, y, 0.9), ["component", "value ± SE", "meaning"], rows,
                          [0.14, 0.3, 0.56], fontsize=8.5, title=title, max_chars=[14, 30, 64], wrap=True)
    # (every value whole, wrapped: its verdict -- "not resolved", "< x" -- is never cut; the value columns
    # hold as many monospace characters as their width, one spare; a note, in full in components.csv and
    # the key figures, in at most three lines, so that the page keeps its three tables)
    rows = [r[:-1] + [plots.clip(r[-1], 3 * (20 if masked else 30) - 6)] for r in rows]
    if masked:
        return text_table(fig, (0.06, y, 0.9), ["component", "defects excluded", "all pixels", "meaning", "note"],
                          rows, [0.12, 0.21, 0.21, 0.3, 0.16], fontsize=8, title=title,
                          max_chars=[12, 22, 22, 40, 20], wrap=True)
    return text_table(fig, (0.06, y, 0.9), ["component", "value ± SE", "meaning", "note"], rows,
                      [0.14, 0.28, 0.34, 0.24], fontsize=8.5, title=title, max_chars=[14, 27, 40, 30], wrap=True)


def components_page(run, mid: dict | None, dark: dict | None):
    fig = new_page("Noise components (ANOVA, view 'full')",
                   "model v = o+Cs+Ct+Rs+Rt+Ps+Pt+G·Cg·Rg·Pg·(q+delta); variances in DN^2, Cg/Rg/Pg in % rms")
    y = 0.92
    if mid is not None:
        s = ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}" for k, v in mid["settings"].items())
        mtf = (getattr(run, "analyses", None) or {}).get("mtf")
        edge = isinstance(mtf, dict) and mid["name"] in (mtf.get("stages") or {})
        y = _component_table(fig, y, mid, "components", f"mid-level stage {mid['name']} ({mid['scene']})", edge)
        fig.text(0.06, y - 0.003, plots.clip("settings: " + s, 130), fontsize=7.5, va="top", color="0.3")
        y -= 0.04
        if "flat_anova" in mid["views"]["full"]:
            y = _component_table(fig, y, mid, "flat_anova", f"ANOVA of the flat stack itself ({mid['name']}, "
                                                            "all pixels)", edge)
            y -= 0.03
    if dark is not None and dark is not mid and y > 0.3:
        _component_table(fig, y, dark, "components", f"dark stage {dark['name']}")
    return fig


VIEW_COLUMNS = ("Pt", "Ps", "Rt", "Rs", "Ct", "Cs", "G", "Pg")


def _num(x) -> str:
    return "n/a" if x is None else f"{x:.4g}"


def _view_cell(c: str, d: dict) -> str:
    """A component's value in the per-view table as every other surface judges it (gain spreads
    in % rms; a limit "< x", not its bound as if measured; "n/a"), without its SE and reason
    (components.csv and the components page hold them)."""
    return tables.component_display(c, d)[0].split(" (")[0].split(" ± ")[0]


def views_page(stage: dict):
    """The main components of every view (regions, CFA phases, ADC channels) of a stage;
    the full frame also without its defect pixels where a mask was applied (the values
    the terminal and the key figures state)."""
    fig = new_page(f"Components per view: stage {stage['name']}",
                   "variances in DN^2, G in DN/e-, Pg in % rms; '(masked)': defect pixels excluded; "
                   "standard errors in components.csv")
    rows = []
    listed = []
    for view, v in stage["views"].items():
        listed.append((view, v.get("components") or {}, v.get("level") or {}))
        if v.get("components_masked"):
            listed.append((f"{view} (masked)", v["components_masked"], v.get("level_masked") or {}))
    for view, comps, lv in listed:
        rows.append([view, str(lv.get("n_pixels", "")), _num(lv.get("mean_dn")), _num(lv.get("var_dn2"))]
                    + [_view_cell(c, comps.get(c) or {}) for c in VIEW_COLUMNS])
    y = text_table(fig, (0.04, 0.92, 0.93), ["view", "pixels", "mean", "var"] + list(VIEW_COLUMNS), rows[:30],
                   [0.13, 0.07, 0.08, 0.08] + [0.08] * len(VIEW_COLUMNS), fontsize=7.5,
                   max_chars=[18, 8, 9, 9] + [9] * len(VIEW_COLUMNS))
    var_c = [c for c in VIEW_COLUMNS if c not in ("G", "Pg")]
    views = list(stage["views"])[:12]
    if y > 0.35:
        h = min(0.4, y - 0.15)
        ax = fig.add_axes([0.1, y - 0.07 - h, 0.85, h])
        w = 0.8 / len(views)
        for k, view in enumerate(views):
            comps = stage["views"][view].get("components") or {}
            vals = [(comps.get(c) or {}).get("value") for c in var_c]
            ses = [(comps.get(c) or {}).get("se") for c in var_c]
            x = np.arange(len(var_c)) + (k - (len(views) - 1) / 2) * w
            ax.bar(x, [np.nan if v is None or v <= 0 else v for v in vals], w,
                   yerr=[0 if e is None else e for e in ses], capsize=1.5, label=view)
        ax.set_xticks(range(len(var_c)), var_c)
        ax.set_yscale("log")
        ax.set_ylabel("variance (DN^2)")
        ax.set_title("variance components per view (non-positive estimates not drawn)")
        ax.grid(alpha=0.3, axis="y", which="both")
        ax.legend(ncol=4, fontsize=7)
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
                     page_tables.fmt_value(full["level"].get("var_dn2")),
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
                   [0.04, 0.13, 0.06, 0.1, 0.1, 0.1, 0.1, 0.37], fontsize=7,
                   max_chars=[5, 18, 6, 10, 11, 11, 11, 60])
        figs.append(fig)
    return figs


def emva_sheet(run):
    """(Release 4.0 Linear sheet, General result) when the scan ran the ``emva4`` analysis,
    recomputed from the run's stage results and averaged images (the graphs need them);
    None otherwise or when that fails (said in the report's notes)."""
    if not scan_kinds.available(run, "emva4"):
        return None
    from ares.results.emva4 import evaluate
    from ares.rundir.record import load_run

    try:
        sheet, general, why = evaluate(load_run(run.dir))
    except Exception as exc:  # noqa: BLE001 -- the rest of the report stands without these pages
        run.notes.append(f"EMVA 1288 datasheet not drawn: {type(exc).__name__}: {exc}")
        return None
    if sheet is None:
        run.notes.append(f"EMVA 1288 datasheet not drawn: {why}")
        return None
    stmt = k_statement_of(run)
    if stmt:  # the datasheet's K (Eq. 50) and the report's headline K: the same sentence on both
        sheet.notes.append(stmt)
    return sheet, general


def k_statement_of(run) -> str:
    """The sentence naming the headline K beside the EMVA 1288 4.0 Eq. 50 K ("" without one)."""
    return (((run.analyses.get("ptc") or {}).get("gain_headline") or {}).get("statement") or "")


def page_plan(run, groups=None, kf=None, emva=None) -> list[tuple[str, object]]:
    """The report's pages in order as (title, maker): a maker is a callable drawing the
    page (``Figure``) or, for pages that come in a data-dependent number, the ``Figure``
    itself. Deterministic from the run directory, so that another process that plans
    the same run draws the same page under the same number (``ares.report.pdf_parts``)."""
    groups = tables.ptc_groups(run) if groups is None else groups
    kf = tables.compute_key_figures(run, groups) if kf is None else kf
    chunks = key_figure_chunks(run, kf)
    pages = [("title", partial(title_page, run, kf, chunks))]
    for k in range(1, len(chunks)):  # every key figure in the PDF: those the title page has no room for
        pages.append((f"key figures {k + 1}", partial(key_figure_pages.continuation_page, chunks[k], k + 1,
                                                      len(chunks), sum(len(c) for c in chunks[k + 1:]))))
    ptc_ok = [g for g in groups if g.result is not None and g.is_curve]
    for g in ptc_ok:
        rows = tables.ptc_rows([g])
        pages.append((f"ptc x{g.analog_gain:g}", partial(ptc_page, g, rows)))
        pages.append((f"snr x{g.analog_gain:g}", partial(snr_linearity_page, g, rows)))
        if len(ptc_ok) > 2:  # many gains: the first gain in full, the rest on the gain page
            break
    mid, dark = tables.mid_stage(run), tables.dark_stage(run)
    if mid is not None:
        pages.append(("components", partial(components_page, run, mid, dark)))
        if len(mid["views"]) > 1:
            pages.append(("views", partial(views_page, mid)))
    for st in [s for s in (mid, dark) if s is not None]:
        if run.has_array(st["index"], "mean"):
            pages.append((f"maps {st['name']}", partial(_maps_page, run, st)))
        if st is dark:
            break
    pages += scan_kinds.pages(run, groups)
    if emva is not None:  # the EMVA 1288 datasheet pages (also written alone as emva_datasheet.pdf)
        from ares.report import datasheet

        pages += datasheet.pages(*emva)
        if emva[1] is not None:  # Release 4.0 General's own summary and graphs (its other pages repeat these)
            pages += [(t, f) for t, f in datasheet.pages(*emva, "4.0-general") if t in ("EMVA General summary",
                                                                                        "EMVA general")]
    pages += [("stages", f) for f in stages_pages(run)]
    return pages


def _maps_page(run, st):
    return maps_page(run, st, run.arrays(st["index"]))


def draw_page(run, pages, i: int):
    """Page ``i`` of a plan drawn, with its footer (page i of n)."""
    maker = pages[i][1]
    fig = maker() if callable(maker) else maker
    fig.text(0.5, 0.012, f"{run.meta.get('scan_name', '')} · {run.dir.resolve().name} · page {i + 1} of "
             f"{len(pages)}" + (f" · {run.attribution}" if run.attribution else ""), ha="center", fontsize=7,
             color="0.4")
    return fig


def build_pages(run, groups=None, kf=None, emva=None) -> list[tuple[str, object]]:
    """Every page drawn: (title, Figure)."""
    pages = page_plan(run, groups, kf, emva)
    return [(t, draw_page(run, pages, i)) for i, (t, _) in enumerate(pages)]


def render(run, pages, indices, path: Path) -> None:
    """Draw the pages ``indices`` of a plan into the PDF ``path`` (in that order)."""
    from matplotlib.backends.backend_pdf import PdfPages

    with matplotlib.rc_context(plots.RC), \
            PdfPages(path, metadata={"Title": f"ARES report {run.meta.get('scan_name', '')}",
                                     "Creator": "ares report"}) as pdf:
        for i in indices:
            fig = draw_page(run, pages, i)
            pdf.savefig(fig)
