"""The lot PDF, for lots of any size: summary pages (counts, yield per limit with its
denominator, the distribution of each limited quantity, wafer maps of pass/fail, of bins
and of each limited quantity with failed and errored dies coloured) and an appendix with
every item and every error, paginated -- nothing left out, nothing clipped without saying so.

Bins: 0 every limit passed (or not tested), k the first failed limit (in the lot file's
order), E could not be analysed.
"""

from __future__ import annotations

import math
import os
import textwrap
from pathlib import Path

ROWS_PER_PAGE = 58
COLOURS = {"pass": "#2ca02c", "FAIL": "#d62728", "error": "#7f7f7f", "no limits set": "#1f77b4"}


def bin_of(r: dict, limit_texts: list[str]) -> str:
    if r.get("status") == "error":
        return "E"
    for k, lt in enumerate(limit_texts, 1):
        if r.get("checks", {}).get(lt) is False:
            return str(k)
    return "0"


def _cell(r: dict, q: str) -> str:
    from ares.analysis.stats.estimate import format_value
    from ares.batch.lot_report import find

    f = find(r.get("figures") or {}, q) or {}
    v = f.get("value")
    if v is None:
        return "not measured" if r.get("status") != "error" else "-"
    return f"{format_value(v, f.get('se'))} {f.get('unit', '')}".strip()


def _wrap(s: str, width: int) -> list[str]:
    return textwrap.wrap(s, width, break_long_words=True, break_on_hyphens=False) or [""]


def _summary(j, lot_name: str):
    from ares.batch.lot_report import NO_LIMITS, verdict
    from ares.report.plots import new_page, text_table

    n = len(j.results)
    counts = {}
    for r in j.results:
        v = verdict(r, j.limits)
        counts[v] = counts.get(v, 0) + 1
    sub = f"{n} item(s): " + ", ".join(f"{c} {k}" for k, c in counts.items())
    fig = new_page(f"Lot report: {lot_name}", sub)
    if j.limits:
        rows = [[f"{k}. {lt}", str(a), str(b), f"{100 * a / b:.1f} %" if b else "n/a"]
                for k, (lt, (a, b)) in enumerate(j.yields.items(), 1)]
        y = text_table(fig, (0.06, 0.92, 0.88), ["bin. limit", "passed", "of items", "yield"], rows,
                       [0.55, 0.13, 0.13, 0.19], fontsize=8, title="Yield per limit")
        fig.text(0.06, y - 0.01, "The denominator is every item of the lot: an item that could not be analysed "
                                 "counts as failed; an item without the quantity is 'not tested' for that limit.",
                 fontsize=7, color="0.3", va="top", wrap=True)
    else:
        fig.text(0.06, 0.9, f"{NO_LIMITS}: the lot file declares no limits, so no item is judged pass or fail.",
                 fontsize=10, va="top")
    errs = sum(r.get("status") == "error" for r in j.results)
    fig.text(0.06, 0.08, f"Every item is listed in the appendix ({n} item(s)); every error message in full "
                         f"({errs} error(s)) after it.", fontsize=8, va="bottom")
    return fig


def _wafer_pages(j):
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from ares.batch.lot_report import find, limit_text, verdict
    from ares.report.plots import A4

    placed = [r for r in j.results if r.get("x") is not None]
    if not placed:
        return []
    xs = [r["x"] for r in placed]
    ys = [r["y"] for r in placed]
    size = max(4.0, min(300.0, 30000.0 / max(len(placed), 1)))
    fig = Figure(figsize=A4)
    fig.text(0.5, 0.97, "Wafer maps: verdict and bin", ha="center", va="top", fontsize=13, weight="bold")
    ax = fig.add_axes([0.12, 0.55, 0.76, 0.37])
    v = [verdict(r, j.limits) for r in placed]
    ax.scatter(xs, ys, c=[COLOURS[k] for k in v], s=size, marker="s")
    ax.legend([Line2D([], [], ls="none", marker="s", color=COLOURS[k]) for k in COLOURS if k in v],
              [f"{k} ({v.count(k)})" for k in COLOURS if k in v], loc="upper left", bbox_to_anchor=(1.0, 1.0),
              fontsize=7)
    ax.set(xlabel="wafer x", ylabel="wafer y", title="verdict per die", aspect="equal")
    lts = list(j.yields)
    bins = [bin_of(r, lts) for r in placed]
    names = sorted(set(bins), key=lambda b: (b == "E", b.zfill(4)))
    bx = fig.add_axes([0.12, 0.08, 0.76, 0.37])
    import matplotlib

    cmap = matplotlib.colormaps["tab10"]
    col = {b: ("#2ca02c" if b == "0" else "#7f7f7f" if b == "E" else cmap((int(b) + 2) % 10)) for b in names}
    bx.scatter(xs, ys, c=[col[b] for b in bins], s=size, marker="s")
    bx.legend([Line2D([], [], ls="none", marker="s", color=col[b]) for b in names],
              [f"bin {b}: " + ("pass" if b == "0" else "error" if b == "E" else lts[int(b) - 1]) +
               f" ({bins.count(b)})" for b in names], loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=6)
    bx.set(xlabel="wafer x", ylabel="wafer y", title="bin per die (first failed limit)", aspect="equal")
    pages = [fig]
    for lim in j.limits:
        fig = Figure(figsize=A4)
        fig.text(0.5, 0.97, f"Wafer map: {lim.quantity}", ha="center", va="top", fontsize=13, weight="bold")
        ax = fig.add_axes([0.1, 0.3, 0.72, 0.6])
        val = [(r, (find(r.get("figures") or {}, lim.quantity) or {}).get("value")) for r in placed]
        good = [(r["x"], r["y"], float(x)) for r, x in val if x is not None and math.isfinite(float(x))]
        if good:
            gx, gy, gv = zip(*good)
            sc = ax.scatter(gx, gy, c=gv, s=size, marker="s", cmap="viridis")
            fig.colorbar(sc, ax=ax, label=lim.quantity)
        failed = [(r["x"], r["y"]) for r, _ in val if r.get("status") != "error"
                  and r.get("checks", {}).get(limit_text(lim)) is False]
        err = [(r["x"], r["y"]) for r, x in val if r.get("status") == "error" or x is None]
        if failed:
            ax.scatter(*zip(*failed), s=size, marker="s", facecolors="none", edgecolors=COLOURS["FAIL"], lw=1.2,
                       label=f"outside the limit ({len(failed)})")
        if err:
            ax.scatter(*zip(*err), s=size, marker="s", color=COLOURS["error"],
                       label=f"error / not measured ({len(err)})")
        if failed or err:
            ax.legend(loc="upper left", bbox_to_anchor=(0, -0.08), fontsize=7)
        ax.set(xlabel="wafer x", ylabel="wafer y", aspect="equal")
        pages.append(fig)
    return pages


def _distributions(j):
    from matplotlib.figure import Figure

    from ares.batch.lot_report import find
    from ares.report.plots import A4

    pages = []
    for lim in j.limits:
        vals = [(find(r.get("figures") or {}, lim.quantity) or {}).get("value") for r in j.results]
        vals = [float(v) for v in vals if v is not None and math.isfinite(float(v))]
        if not vals:
            continue
        fig = Figure(figsize=A4)
        fig.text(0.5, 0.97, f"{lim.quantity} over the lot", ha="center", va="top", fontsize=13, weight="bold")
        ax = fig.add_axes([0.12, 0.55, 0.78, 0.35])
        ax.hist(vals, bins=min(50, max(5, int(math.sqrt(len(vals))))), color="C0")
        for b in (lim.min, lim.max):
            if b is not None:
                ax.axvline(b, color="C3", ls="--", lw=1)
        ax.set(xlabel=lim.quantity, ylabel="items",
               title=f"distribution ({len(vals)} of {len(j.results)} items measured); limit {lim.bounds()}")
        pages.append(fig)
    return pages


def _appendix(j):
    from ares.batch.lot_report import verdict
    from ares.report.plots import new_page

    items = [r["item"] for r in j.results]
    try:
        base = os.path.commonpath(items) if len(items) > 1 else str(Path(items[0]).parent)
    except ValueError:
        base = ""
    if base in items:
        base = str(Path(base).parent)
    show = [lim.quantity for lim in j.limits][:3] or j.quantities[:3]
    lts = list(j.yields)
    lines = []  # every item, its name wrapped (never clipped) over as many lines as it needs
    for k, r in enumerate(j.results, 1):
        name = os.path.relpath(r["item"], base) if base else r["item"]
        parts = _wrap(name, 34)
        first = [str(k), parts[0], r.get("sensor", "") or "-", verdict(r, j.limits), bin_of(r, lts)] + \
            [_cell(r, q) for q in show]
        lines.append(first)
        lines += [["", p, "", "", ""] + [""] * len(show) for p in parts[1:]]
    header = ["#", "item", "serial", "verdict", "bin", *show]
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
                       f"{len(j.results)} item(s), paths relative to {base or '/'}")
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

    pages = [_summary(j, lot_name), *_distributions(j), *_wafer_pages(j), *_appendix(j)]
    tmp = path.with_name(path.name + ".tmp")
    with matplotlib.rc_context(RC), PdfPages(tmp) as pdf:
        for f in pages:
            pdf.savefig(f)
    tmp.replace(path)
