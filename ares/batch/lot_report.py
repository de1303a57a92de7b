"""The lot report: one table with every item's key figures, their SEs and verdicts, pass/fail
against the lot's limits and the yield per limit (CSV, HDF5, PDF); the PDF adds the
distribution of each limited quantity over the lot and, when the lot file gives wafer
positions, wafer maps (``ares.batch.lot_pdf``)."""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class Judged:
    results: list[dict]  # per item (items.process), with "sensor", "x", "y", "checks", "passed"
    limits: list  # ares.protocol.scan.Limit
    quantities: list[str]  # the figure names in the table (union over the items, first-seen order)
    yields: dict[str, tuple[int, int]]  # limit or screen text -> (passed, judged)
    screens: list[dict] = field(default_factory=list)  # static limits and dynamic screens (ares.batch.screens)
    bins: dict[int, dict] = field(default_factory=dict)  # soft bin -> {hard, name, count}


def limit_text(lim) -> str:
    from ares.batch.vocabulary import canonical

    return f"{canonical(lim.quantity)} {lim.bounds()}"


def find(figures: dict, quantity: str) -> dict | None:
    """The figure a limit names, by its canonical name (``K`` and ``gain_dn_per_e`` are one
    quantity): its key, or a dotted path ending in it (as scan limits)."""
    from ares.batch.vocabulary import canonical
    from ares.results.registry import names_quantity

    if quantity in figures:  # a figure's own key (``emva4.values.K``, whose canonical form names another)
        return figures[quantity]
    quantity = canonical(quantity)
    if quantity in figures:
        return figures[quantity]
    return next((v for k, v in figures.items() if names_quantity(k, quantity)), None)


def figure_verdict(f: dict) -> str:
    """A figure's verdict column (lot.csv, lot.h5, the database): a declared figure's "exact:
    why" (its SE 0 says no more), else its verdict ("ok", "upper limit", ...)."""
    from ares.analysis.stats.estimate import exact_text

    if f.get("exact") or (f.get("se") == 0 and f.get("value") is not None and f.get("verdict") in ("", "ok", None)):
        return exact_text(f.get("exact", ""))
    return f.get("verdict") or ""


NO_LIMITS = "no limits set"
NOT_TESTED = "not tested"


def judge(results: list[dict], limits, meta: dict[str, dict] | None = None) -> Judged:
    """Each item against each limit: "pass", "FAIL", or "not tested" (the item has no such
    quantity); an item that could not be analysed fails every limit. Yield per limit is
    passed / every item of the lot (errored ones included: the denominator is the lot)."""
    from ares.results.registry import limit_passes

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
        err = r.get("status") == "error"
        ok = True
        for lim in limits:
            y = yields[limit_text(lim)]
            y[1] += 1
            if err:
                r["checks"][limit_text(lim)] = False
                continue
            f = find(r.get("figures") or {}, lim.quantity)
            good = None if f is None else limit_passes(lim, f)  # (a figure known only as a limit: where it proves it)
            r["checks"][limit_text(lim)] = good
            y[0] += int(bool(good))
            ok &= good is not False
        r["passed"] = False if err else (ok if limits else None)
    return Judged(results, list(limits), quantities, {k: (a, b) for k, (a, b) in yields.items()})


def verdict(r: dict, limits) -> str:
    if r.get("status") == "error":
        return "error"
    if not limits and r.get("hard_bin") is None:
        return NO_LIMITS
    return "pass" if r.get("passed") else "FAIL"


# the fixed columns of lot.csv / lot.h5, in this order, whatever the items' kinds
COLUMNS = ("item", "serial", "lot", "wafer", "x", "y", "kind", "status", "verdict", "error", "run_dir",
           "content_hash", "ares_version", "started", "hard_bin", "soft_bin")


def rows(j: Judged, lot: str = "") -> tuple[list[dict], list[str]]:
    cols = list(COLUMNS) + [c for q in j.quantities for c in (q, f"{q}_se", f"{q}_unit", f"{q}_verdict")] + \
        list(j.yields)
    out = []
    for r in j.results:
        row = {"item": r["item"], "serial": r.get("sensor", ""), "lot": lot, "wafer": r.get("wafer", ""),
               "x": r.get("x"), "y": r.get("y"), "kind": r.get("kind", ""), "status": r.get("status"),
               "verdict": verdict(r, j.limits), "error": r.get("error", ""),
               "run_dir": r["item"] if r.get("kind") == "run" else "", "content_hash": r.get("hash", ""),
               "ares_version": r.get("ares_version", ""), "started": r.get("started", ""),
               "hard_bin": r.get("hard_bin"), "soft_bin": r.get("soft_bin")}
        for q in j.quantities:
            f = (r.get("figures") or {}).get(q) or {}
            row[q] = f.get("value")
            row[f"{q}_se"] = f.get("se")
            row[f"{q}_unit"] = f.get("unit", "")
            row[f"{q}_verdict"] = figure_verdict(f) if f else "not measured"
        for k, v in r.get("checks", {}).items():
            row[k] = NOT_TESTED if v is None else ("pass" if v else "FAIL")
        out.append(row)
    return out, cols


def to_csv(j: Judged, lot: str = "") -> str:
    data, cols = rows(j, lot)
    buf = io.StringIO()
    w = csv.DictWriter(buf, cols, lineterminator="\n")
    w.writeheader()
    for r in data:
        w.writerow({k: ("" if v is None else (repr(float(v)) if isinstance(v, float) else v)) for k, v in r.items()})
    return buf.getvalue()


FIXED_MEANING = {
    "item": "the item's path", "serial": "sensor serial", "lot": "lot name", "wafer": "wafer", "x": "die x on the wafer",
    "y": "die y on the wafer", "kind": "item kind (run, emva, stack)", "status": "the item's run status",
    "verdict": "pass / FAIL / error / no limits set", "error": "why the item could not be analysed",
    "run_dir": "its run directory", "content_hash": "SHA-256 of the item's content",
    "ares_version": "the ARES version that analysed it", "started": "when the item was measured",
    "hard_bin": "hard bin", "soft_bin": "soft bin"}


def columns_csv(j: Judged, lot: str = "") -> str:
    """lot_columns.csv: what each column of lot.csv holds -- lot.csv keeps machine keys (its
    readers, lot.h5 and the database use them), this says, row by row, the label the scan
    surfaces and the lot PDF give each quantity and its unit (``vocabulary.quantity_label``)."""
    from ares.batch.vocabulary import quantity_label

    data, cols = rows(j, lot)
    unit = {q: next((r[f"{q}_unit"] for r in data if r.get(f"{q}_unit")), "") for q in j.quantities}
    out = []
    for c in cols:
        if c in FIXED_MEANING:
            out.append((c, FIXED_MEANING[c], ""))
        elif c in j.yields:
            out.append((c, f"outcome of the limit or screen '{c}': pass / FAIL / {NOT_TESTED}", ""))
        else:
            q, what = next(((q, c[len(q):]) for q in j.quantities if c == q or c.startswith(q + "_")
                            and c[len(q):] in ("_se", "_unit", "_verdict")), (c, ""))
            label = quantity_label(q)
            out.append((c, {"": label, "_se": f"SE of {label}", "_unit": f"unit of {label}",
                            "_verdict": f"verdict of {label}"}[what], unit.get(q, "") if what in ("", "_se") else ""))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(("column", "quantity", "unit"))
    w.writerows(out)
    return buf.getvalue()


def write_h5(j: Judged, path: Path, lot_name: str) -> None:
    import h5py

    from ares.batch.vocabulary import quantity_label

    data, cols = rows(j, lot_name)
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs["lot"] = lot_name
        f.attrs["yield"] = json.dumps(j.yields)
        g = f.create_group("items")
        for c in cols:
            vals = [r.get(c) for r in data]
            if c in j.quantities or c.endswith("_se") or c in ("x", "y", "hard_bin", "soft_bin"):
                ds = g.create_dataset(c, data=np.array([np.nan if v is None else float(v) for v in vals], np.float64))
                q = c.removesuffix("_se") if c not in j.quantities else c
                if q in j.quantities:  # what a reader calls it (the lot PDF's, the scan surfaces' label) and its unit
                    ds.attrs["label"] = ("SE of " if c != q else "") + quantity_label(q)
                    ds.attrs["unit"] = next((r[f"{q}_unit"] for r in data if r.get(f"{q}_unit")), "")
            else:
                g.create_dataset(c, data=np.array(["" if v is None else str(v) for v in vals], dtype=object),
                                 dtype=h5py.string_dtype())
    tmp.replace(path)
