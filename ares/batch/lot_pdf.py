"""The lot PDF, for lots of any size: summary pages (counts, yield per limit and per screen
with its denominator, the bins with their yields, every quantity's count, median and
spread), the distribution of every quantity (its static and dynamic limits drawn), wafer
maps of pass/fail, of bins and of each limited quantity with failed and errored dies
coloured, and an appendix with every item and every error, paginated -- nothing left out,
nothing clipped without saying so (every column of every item is in lot.csv / lot.h5).

Bins: the soft bin of ``ares.batch.screens`` (1 pass, a limit's or a screen's bin, 99 could
not be analysed); a lot without limits or screens has none ("-").
"""

from __future__ import annotations

import math
import os
import textwrap
from pathlib import Path

ROWS_PER_PAGE = 58
COLOURS = {"pass": "#2ca02c", "FAIL": "#d62728", "error": "#7f7f7f", "no limits set": "#1f77b4"}


def bin_of(r: dict) -> str:
    return "-" if r.get("soft_bin") is None else str(r["soft_bin"])


def _stats(j) -> list[list[str]]:
    """Every quantity (its label, its lot.csv column): items measured, median, IQR, min, max,
    unit, items known only as a limit (a limit is not a value: it stays out of the median and
    the spread)."""
    import numpy as np

    from ares.batch.lot_report import find
    from ares.batch.vocabulary import quantity_label
    from ares.results.registry import limit_side

    rows = []
    for q in j.quantities:
        fs = [find(r.get("figures") or {}, q) or {} for r in j.results]
        have = [f for f in fs if f.get("value") is not None and math.isfinite(float(f["value"]))]
        v = np.array([float(f["value"]) for f in have if not limit_side(f)])
        n_lim = str(len(have) - v.size)
        unit = next((f.get("unit") for f in fs if f.get("unit")), "")
        if v.size:
            p25, p50, p75 = np.percentile(v, [25, 50, 75])
            rows.append([quantity_label(q), q, str(v.size), f"{p50:.5g}", f"{p75 - p25:.3g}", f"{v.min():.5g}",
                         f"{v.max():.5g}", unit, n_lim])
        else:
            rows.append([quantity_label(q), q, "0", "-", "-", "-", "-", unit, n_lim])
    return rows


def _cell(r: dict, q: str) -> str:
    from ares.batch.lot_report import find
    from ares.report.page_tables import fmt_value

    f = find(r.get("figures") or {}, q) or {}
    v = f.get("value")
    if v is None:
        return "not measured" if r.get("status") != "error" else "-"
    return fmt_value(v, f.get("se"), f.get("unit") or "", f.get("verdict") or "", f.get("exact", ""))  # "< x", "(exact: ...)"


def _wrap(s: str, width: int) -> list[str]:
    return textwrap.wrap(s, width, break_long_words=True, break_on_hyphens=False) or [""]


def _summary(j, lot_name: str):
    from ares.batch.lot_report import NO_LIMITS, limit_text, verdict
    from ares.batch.vocabulary import canonical, quantity_label
    from ares.report.plots import new_page, text_table

    n = len(j.results)
    counts = {}
    for r in j.results:
        v = verdict(r, j.limits)
        counts[v] = counts.get(v, 0) + 1
    sub = f"{n} item(s): " + ", ".join(f"{c} {k}" for k, c in counts.items())
    fig = new_page(f"Lot report: {lot_name}", sub)
    y = 0.92
    if j.yields:
        scr = {s["screen"]: s for s in j.screens}
        what = {**{s["screen"]: s["quantity"] for s in j.screens}, **{limit_text(lim): lim.quantity for lim in j.limits}}
        rows = [[quantity_label(canonical(what[lt])) if lt in what else "-",
                 lt + (f" [{scr[lt]['low']:.4g}, {scr[lt]['high']:.4g}]" if scr.get(lt, {}).get("kind") == "dynamic"
                       and scr[lt].get("low") is not None else ""), str(a), str(b), f"{100 * a / b:.1f} %" if b else "n/a"]
                for lt, (a, b) in j.yields.items()]
        y = text_table(fig, (0.06, y, 0.88), ["quantity", "limit or screen (lot.csv column)", "passed", "of items",
                                              "yield"], rows,
                       [0.26, 0.44, 0.1, 0.1, 0.1], fontsize=7, title="Yield per limit and per screen",
                       max_chars=[40, 70, 8, 8, 8], wrap=True)
        fig.text(0.06, y - 0.005, "The denominator is every item of the lot: an item that could not be analysed "
                                  "counts as failed; an item without the quantity (or failed before a screen) is "
                                  "'not tested' for it. Screens: median +- k robust sigma of the items that passed "
                                  "the static limits.", fontsize=6.5, color="0.3", va="top", wrap=True)
        y -= 0.05
    if j.bins:
        rows = [[f"{b['hard']} {b.get('hard_name', '')} ({'pass' if b.get('pass') else 'fail'})", str(sb), b["name"],
                 str(b["count"]), f"{100 * b['count'] / n:.1f} %"] for sb, b in j.bins.items()]
        y = text_table(fig, (0.06, y, 0.88), ["hard bin", "soft bin", "meaning", "items", "yield"], rows,
                       [0.3, 0.08, 0.4, 0.08, 0.14], fontsize=7, title="Bins", max_chars=[48, 8, 64, 8, 10])
        y -= 0.02
    if not j.yields:
        fig.text(0.06, y, f"{NO_LIMITS}: the lot file declares no limits or screens (or there is no lot file), "
                          f"so no item is judged pass or fail or binned.", fontsize=9, va="top")
        y -= 0.04
    errs = sum(r.get("status") == "error" for r in j.results)
    fig.text(0.06, 0.05, f"Every item is listed in the appendix ({n} item(s)); every error message in full "
                         f"({errs} error(s)) after it;\nevery quantity's median and spread on the next page(s).",
             fontsize=8, va="bottom")
    return fig


def _stats_pages(j):
    from ares.report.plots import new_page, text_table

    rows = _stats(j)
    per = 50  # (a long label wraps onto a second line)
    pages = []
    for p in range(0, len(rows), per):
        fig = new_page(f"Every quantity over the lot ({p // per + 1}/{math.ceil(len(rows) / per)})",
                       f"{len(rows)} quantities of {len(j.results)} item(s), all in lot.csv / lot.h5; "
                       "a limit is not a value: counted under 'limits'")
        text_table(fig, (0.04, 0.92, 0.92), ["quantity", "lot.csv column", "items", "median", "IQR", "min", "max",
                                             "unit", "limits"],
                   rows[p:p + per], [0.27, 0.15, 0.05, 0.1, 0.08, 0.1, 0.1, 0.09, 0.06], fontsize=6.5,
                   max_chars=[40, 26, 6, 12, 10, 12, 12, 10, 6], wrap=True)  # (wrapped, never clipped)
        pages.append(fig)
    return pages


def _side_by_side(placed: list[dict]) -> tuple[dict, dict]:
    """({id(item): (x, y) on the map}, {wafer: where its name goes}): the dies of several wafers
    share coordinates (each wafer's own), so each wafer is shifted right of the one before
    (a gap of two dies) -- drawn at their own x they hid one another."""
    names = sorted({str(r.get("wafer") or "") for r in placed})
    x0, x1 = min(r["x"] for r in placed), max(r["x"] for r in placed)
    y1 = max(r["y"] for r in placed)
    step = (x1 - x0) + 2
    shift = {w: i * step for i, w in enumerate(names)} if len(names) > 1 else {w: 0 for w in names}
    at = {id(r): (r["x"] + shift[str(r.get("wafer") or "")], r["y"]) for r in placed}
    return at, ({w or "(no wafer)": (x0 + shift[w], y1 + 0.6) for w in names} if len(names) > 1 else {})


def _wafer_pages(j):
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from ares.batch.lot_report import find, limit_text, verdict
    from ares.batch.vocabulary import canonical, quantity_heading, quantity_label
    from ares.report.plots import A4

    placed = [r for r in j.results if r.get("x") is not None]
    if not placed:
        return []
    at, wafer_names = _side_by_side(placed)
    xs = [at[id(r)][0] for r in placed]
    ys = [at[id(r)][1] for r in placed]

    def wafers(ax):  # each wafer's name over its dies (several wafers: side by side, never one over another)
        for name, (x, y) in wafer_names.items():
            ax.text(x, y, name, fontsize=7, ha="left", va="bottom")
    size = max(4.0, min(300.0, 30000.0 / max(len(placed), 1)))
    fig = Figure(figsize=A4)
    fig.text(0.5, 0.97, "Wafer maps: verdict and bin", ha="center", va="top", fontsize=13, weight="bold")
    ax = fig.add_axes([0.12, 0.55, 0.76, 0.37])
    v = [verdict(r, j.limits) for r in placed]
    ax.scatter(xs, ys, c=[COLOURS[k] for k in v], s=size, marker="s")
    ax.legend([Line2D([], [], ls="none", marker="s", color=COLOURS[k]) for k in COLOURS if k in v],
              [f"{k} ({v.count(k)})" for k in COLOURS if k in v], loc="upper left", bbox_to_anchor=(1.0, 1.0),
              fontsize=7)
    wafers(ax)
    ax.set(xlabel="wafer x", ylabel="wafer y", aspect="equal")
    ax.set_title("verdict per die", pad=14)  # (above the wafers' names)
    bins = [bin_of(r) for r in placed]
    names = sorted(set(bins), key=lambda b: (b == "-", b.zfill(4)))
    bx = fig.add_axes([0.1, 0.08, 0.6, 0.37])  # (its legend at the right, wrapped: never past the page)
    import matplotlib

    cmap = matplotlib.colormaps["tab10"]
    good = {str(sb) for sb, b in j.bins.items() if b.get("pass")}
    fails = (3, 1, 4, 5, 6, 8, 9, 0)  # tab10 without its green (a passing bin's) and grey (not binned), in bin order
    failing = [b for b in names if b not in good and b != "-"]
    col = {b: ("#2ca02c" if b in good else "#7f7f7f" if b == "-" else cmap(fails[failing.index(b) % len(fails)]))
           for b in names}
    bx.scatter(xs, ys, c=[col[b] for b in bins], s=size, marker="s")
    label = {str(sb): b["name"] for sb, b in j.bins.items()}
    bx.legend([Line2D([], [], ls="none", marker="s", color=col[b]) for b in names],
              ["\n".join(_wrap(f"bin {b}: {label.get(b, 'not binned')} ({bins.count(b)})", 34)) for b in names],
              loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=6)
    wafers(bx)
    bx.set(xlabel="wafer x", ylabel="wafer y", aspect="equal")
    bx.set_title("bin per die (soft bin)", pad=14)  # (above the wafers' names)
    pages = [fig]
    for lim in j.limits:
        fig = Figure(figsize=A4)
        fig.text(0.5, 0.97, f"Wafer map: {quantity_label(canonical(lim.quantity))}", ha="center", va="top",
                 fontsize=13, weight="bold")
        fig.text(0.5, 0.93, f"limit {limit_text(lim)}", ha="center", va="top", fontsize=9)
        ax = fig.add_axes([0.1, 0.3, 0.72, 0.6])
        found = [(r, find(r.get("figures") or {}, lim.quantity) or {}) for r in placed]
        val = [(r, f.get("value")) for r, f in found]
        unit = next((f.get("unit") for _, f in found if f.get("unit")), "")
        good = [(*at[id(r)], float(x)) for r, x in val if x is not None and math.isfinite(float(x))]
        if good:
            gx, gy, gv = zip(*good)
            sc = ax.scatter(gx, gy, c=gv, s=size, marker="s", cmap="viridis")
            fig.colorbar(sc, ax=ax, label=quantity_heading(canonical(lim.quantity), unit))
        failed = [at[id(r)] for r, _ in val if r.get("status") != "error"
                  and r.get("checks", {}).get(limit_text(lim)) is False]
        err = [at[id(r)] for r, x in val if r.get("status") == "error" or x is None]
        if failed:
            ax.scatter(*zip(*failed), s=size, marker="s", facecolors="none", edgecolors=COLOURS["FAIL"], lw=1.2,
                       label=f"outside the limit ({len(failed)})")
        if err:
            ax.scatter(*zip(*err), s=size, marker="s", color=COLOURS["error"],
                       label=f"error / not measured ({len(err)})")
        if failed or err:
            ax.legend(loc="upper left", bbox_to_anchor=(0, -0.08), fontsize=7)
        wafers(ax)
        ax.set(xlabel="wafer x", ylabel="wafer y", aspect="equal")
        pages.append(fig)
    return pages


def _distributions(j):
    """Every quantity's histogram, six a page; its static limits (red dashed) and dynamic
    screen limits (orange dotted) drawn."""
    from ares.batch.lot_report import find, limit_text
    from ares.batch.vocabulary import canonical, quantity_heading
    from ares.report.plots import new_page
    from ares.results.registry import limit_side

    lines: dict[str, list[tuple[float, str]]] = {}
    for lim in j.limits:
        scr = next((s for s in j.screens if s["screen"] == limit_text(lim)), {})
        lines.setdefault(canonical(lim.quantity), []).extend((b, "static") for b in (scr.get("low"), scr.get("high"))
                                                             if b is not None)
    for s_ in j.screens:
        if s_["kind"] == "dynamic":
            lines.setdefault(canonical(s_["quantity"]), []).extend(
                (b, "dynamic") for b in (s_.get("low"), s_.get("high")) if b is not None)
    qs = [canonical(lim.quantity) for lim in j.limits]
    qs += [q for q in j.quantities if q not in qs]
    plots = []
    for q in qs:
        fs = [find(r.get("figures") or {}, q) or {} for r in j.results]
        vals = [f.get("value") for f in fs if not limit_side(f)]  # (a limit is not a value: as the table)
        vals = [float(v) for v in vals if v is not None and math.isfinite(float(v))]
        if vals:
            plots.append((q, vals, next((f.get("unit") for f in fs if f.get("unit")), "")))
    pages = []
    for p in range(0, len(plots), 6):
        fig = new_page(f"Distributions ({p // 6 + 1}/{math.ceil(len(plots) / 6)})",
                       "items per value; red dashed: static limits, orange dotted: dynamic (PAT) limits")
        for k, (q, vals, unit) in enumerate(plots[p:p + 6]):
            ax = fig.add_axes([0.1 + 0.47 * (k % 2), 0.66 - 0.3 * (k // 2), 0.37, 0.22])
            ax.hist(vals, bins=min(50, max(5, int(math.sqrt(len(vals))))), color="C0")
            for b, kind in lines.get(q, []):
                ax.axvline(b, color="C3" if kind == "static" else "C1", ls="--" if kind == "static" else ":", lw=1)
            ax.set_title(f"{quantity_heading(q, unit)} ({len(vals)} of {len(j.results)})", fontsize=7)
            ax.set_xlabel(f"{q} ({unit})" if unit and unit != "1" else q, fontsize=6)  # (its lot.csv column)
            ax.tick_params(labelsize=6)
        pages.append(fig)
    return pages


def _appendix(j):
    from ares.batch.lot_report import verdict
    from ares.batch.vocabulary import canonical, quantity_label
    from ares.report.plots import new_page

    items = [r["item"] for r in j.results]
    try:
        base = os.path.commonpath(items) if len(items) > 1 else str(Path(items[0]).parent)
    except ValueError:
        base = ""
    if base in items:
        base = str(Path(base).parent)
    show = [lim.quantity for lim in j.limits][:3] or j.quantities[:3]
    lines = []  # every item, its name wrapped (never clipped) over as many lines as it needs
    for k, r in enumerate(j.results, 1):
        name = os.path.relpath(r["item"], base) if base else r["item"]
        parts = _wrap(name, 34)
        first = [str(k), parts[0], r.get("sensor", "") or "-", verdict(r, j.limits), bin_of(r)] + \
            [_cell(r, q) for q in show]
        lines.append(first)
        lines += [["", p, "", "", ""] + [""] * len(show) for p in parts[1:]]
    header = ["#", "item", "serial", "verdict", "bin", *(quantity_label(canonical(q)) for q in show)]
    # one monospaced text block a page (thousands of items: one text object each page, not one
    # a cell); every column as wide as its widest cell, so nothing is clipped
    widths = [max(len(str(c)) for c in col) for col in zip(header, *lines)]
    fmt = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths)).rstrip()  # noqa: E731
    size = min(6.5, 0.92 * 8.27 * 72 / (0.6 * max(sum(widths) + 2 * len(widths), 1)))
    pages = []
    n_pages = max(1, math.ceil(len(lines) / ROWS_PER_PAGE))
    for p in range(n_pages):
        chunk = lines[p * ROWS_PER_PAGE:(p + 1) * ROWS_PER_PAGE]
        fig = new_page(f"Appendix: every item ({p + 1}/{n_pages})",
                       f"{len(j.results)} item(s), paths relative to {base or '/'}; {len(show)} of "
                       f"{len(j.quantities)} quantities shown (all in lot.csv / lot.h5)")
        body = [fmt(header), "-" * len(fmt(header))] + [fmt(c) for c in chunk]
        fig.text(0.04, 0.93, "\n".join(body), fontsize=size, va="top", family="monospace", linespacing=1.25)
        pages.append(fig)
    errs = [(k, r) for k, r in enumerate(j.results, 1) if r.get("status") == "error"]
    if errs:
        elines = []
        for k, r in errs:
            parts = _wrap(r.get("error", ""), 120)
            elines += [f"#{k}: {parts[0]}"] + [f"      {p}" for p in parts[1:]]
        n_pages = math.ceil(len(elines) / 70)
        for p in range(n_pages):
            fig = new_page(f"Appendix: every error ({p + 1}/{n_pages})", f"{len(errs)} item(s) could not be analysed")
            fig.text(0.04, 0.93, "\n".join(elines[p * 70:(p + 1) * 70]), fontsize=6, va="top", family="monospace",
                     color="C3")
            pages.append(fig)
    return pages


def write_pdf(j, path: Path, lot_name: str) -> None:
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    from ares.report.plots import RC

    pages = [_summary(j, lot_name), *_stats_pages(j), *_distributions(j), *_wafer_pages(j), *_appendix(j)]
    tmp = path.with_name(path.name + ".tmp")
    with matplotlib.rc_context(RC), PdfPages(tmp) as pdf:
        for f in pages:
            pdf.savefig(f)
    tmp.replace(path)
