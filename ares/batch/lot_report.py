"""The lot report: one table with every item's key figures, their SEs and verdicts, pass/fail
against the lot's limits and the yield per limit (CSV, HDF5, PDF); the PDF adds the
distribution of each limited quantity over the lot and, when the lot file gives wafer
positions, a wafer map per limited quantity."""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass
class Judged:
    results: list[dict]  # per item (items.process), with "sensor", "x", "y", "checks", "passed"
    limits: list  # ares.protocol.scan.Limit
    quantities: list[str]  # the figure names in the table (union over the items, first-seen order)
    yields: dict[str, tuple[int, int]]  # limit text -> (passed, judged)


def limit_text(lim) -> str:
    return f"{lim.quantity} {lim.bounds()}"


def find(figures: dict, quantity: str) -> dict | None:
    """The figure a limit names: its key, or a dotted path ending in it (as scan limits)."""
    from ares.scan.results import names_quantity

    if quantity in figures:
        return figures[quantity]
    return next((v for k, v in figures.items() if names_quantity(k, quantity)), None)


def judge(results: list[dict], limits, meta: dict[str, dict] | None = None) -> Judged:
    meta = meta or {}
    quantities: list[str] = []
    for r in results:
        for k in r.get("figures") or {}:
            if k not in quantities:
                quantities.append(k)
    yields = {limit_text(lim): [0, 0] for lim in limits}
    for r in results:
        r.update(meta.get(r["item"], {}))
        r["checks"] = {}
        if r.get("status") == "error":
            r["passed"] = None
            continue
        ok = True
        for lim in limits:
            f = find(r.get("figures") or {}, lim.quantity)
            v = None if f is None else f.get("value")
            good = v is not None and lim.check(float(v))
            r["checks"][limit_text(lim)] = good if v is not None else None
            y = yields[limit_text(lim)]
            y[1] += 1
            y[0] += int(good)
            ok &= good
        r["passed"] = ok
    return Judged(results, list(limits), quantities, {k: (a, b) for k, (a, b) in yields.items()})


COLUMNS = ("item", "sensor", "kind", "status", "passed", "error")


def rows(j: Judged) -> tuple[list[dict], list[str]]:
    cols = list(COLUMNS) + [c for q in j.quantities for c in (q, f"{q}_se", f"{q}_unit", f"{q}_verdict")] + \
        list(j.yields)
    out = []
    for r in j.results:
        row = {"item": r["item"], "sensor": r.get("sensor", ""), "kind": r.get("kind", ""), "status": r.get("status"),
               "passed": "" if r.get("passed") is None else ("pass" if r["passed"] else "FAIL"),
               "error": r.get("error", "")}
        for q in j.quantities:
            f = (r.get("figures") or {}).get(q) or {}
            row[q] = f.get("value")
            row[f"{q}_se"] = f.get("se")
            row[f"{q}_unit"] = f.get("unit", "")
            row[f"{q}_verdict"] = f.get("verdict", "") if f else "not measured"
        for k, v in r.get("checks", {}).items():
            row[k] = "n/a" if v is None else ("pass" if v else "FAIL")
        out.append(row)
    return out, cols


def to_csv(j: Judged) -> str:
    data, cols = rows(j)
    buf = io.StringIO()
    w = csv.DictWriter(buf, cols, lineterminator="\n")
    w.writeheader()
    for r in data:
        w.writerow({k: ("" if v is None else (repr(float(v)) if isinstance(v, float) else v)) for k, v in r.items()})
    return buf.getvalue()


def write_h5(j: Judged, path: Path, lot_name: str) -> None:
    import h5py

    data, cols = rows(j)
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs["lot"] = lot_name
        f.attrs["yield"] = json.dumps(j.yields)
        g = f.create_group("items")
        for c in cols:
            vals = [r.get(c) for r in data]
            if c in j.quantities or c.endswith("_se"):
                g.create_dataset(c, data=np.array([np.nan if v is None else float(v) for v in vals], np.float64))
            else:
                g.create_dataset(c, data=np.array(["" if v is None else str(v) for v in vals], dtype=object),
                                 dtype=h5py.string_dtype())
    tmp.replace(path)


def write_pdf(j: Judged, path: Path, lot_name: str) -> None:
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.figure import Figure

    from ares.analysis.estimate import format_value
    from ares.report.plots import A4, RC, new_page, text_table

    pages = []
    n_ok = sum(1 for r in j.results if r.get("passed"))
    n_err = sum(1 for r in j.results if r.get("status") == "error")
    fig = new_page(f"Lot report: {lot_name}", f"{len(j.results)} item(s); {n_ok} pass every limit; "
                                              f"{n_err} could not be analysed")
    y = text_table(fig, (0.06, 0.92, 0.88), ["limit", "passed", "judged", "yield"],
                   [[k, str(a), str(b), f"{100 * a / b:.1f} %" if b else "n/a"] for k, (a, b) in j.yields.items()],
                   [0.5, 0.15, 0.15, 0.2], fontsize=8, title="Yield per limit")
    limited = [lim.quantity for lim in j.limits]
    show = limited or j.quantities[:3]
    table = []
    for r in j.results:
        cells = [Path(r["item"]).name[:28], r.get("sensor", "")[:10],
                 "error" if r.get("status") == "error" else ("pass" if r.get("passed") else
                                                             ("FAIL" if r.get("passed") is False else "-"))]
        for q in show[:3]:
            f = find(r.get("figures") or {}, q) or {}
            v = f.get("value")
            cells.append("n/a" if v is None else format_value(v, f.get("se")) + f" {f.get('unit', '')}")
        table.append(cells)
    text_table(fig, (0.06, y - 0.03, 0.88), ["item", "sensor", "verdict", *show[:3]], table[:45],
               [0.3, 0.12, 0.1] + [0.48 / max(len(show[:3]), 1)] * len(show[:3]), fontsize=7,
               title="Items", max_chars=[28, 10, 8] + [26] * len(show[:3]))
    errs = [r for r in j.results if r.get("status") == "error"]
    if errs:
        fig.text(0.06, 0.05, "\n".join(r["error"][:150] for r in errs[:6]), fontsize=6.5, color="C3", va="bottom")
    pages.append(fig)
    for q in show:
        vals = [(r, (find(r.get("figures") or {}, q) or {}).get("value")) for r in j.results]
        vals = [(r, float(v)) for r, v in vals if v is not None and math.isfinite(float(v))]
        if not vals:
            continue
        fig = Figure(figsize=A4)
        fig.text(0.5, 0.97, f"{q} over the lot", ha="center", va="top", fontsize=13, weight="bold")
        ax = fig.add_axes([0.12, 0.58, 0.78, 0.32])
        ax.hist([v for _, v in vals], bins=min(30, max(5, len(vals))), color="C0")
        lim = next((lm for lm in j.limits if lm.quantity == q), None)
        for b in (lim.min, lim.max) if lim else ():
            if b is not None:
                ax.axvline(b, color="C3", ls="--", lw=1)
        ax.set(xlabel=q, ylabel="items", title=f"distribution ({len(vals)} items)")
        pos = [(r["x"], r["y"], v) for r, v in vals if r.get("x") is not None]
        if pos:
            bx = fig.add_axes([0.12, 0.1, 0.78, 0.38])
            xs, ys, vs = zip(*pos)
            sc = bx.scatter(xs, ys, c=vs, s=300, marker="s", cmap="viridis")
            fig.colorbar(sc, ax=bx, label=q)
            bx.set(xlabel="wafer x", ylabel="wafer y", title="wafer map", aspect="equal")
        pages.append(fig)
    tmp = path.with_name(path.name + ".tmp")
    with matplotlib.rc_context(RC), PdfPages(tmp) as pdf:
        for f in pages:
            pdf.savefig(f)
    tmp.replace(path)
