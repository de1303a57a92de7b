"""Lot trends (``ares lots trend QUANTITY``): one quantity over the lots of a results
database, in lot order -- per lot the items measured, the median and the robust spread
(interquartile range / 1.349) -- with control limits on the lot medians (an individuals
chart: centre the median of the lot medians, limits +- 3 sigma with sigma from the median
moving range / 0.954 -- the median of the range of two normal values in sigmas -- the
robust form of the I-MR chart's mean moving range / 1.128, so one shifted lot does not
widen the limits that should flag it; Wheeler, Montgomery's Introduction to Statistical
Quality Control). A lot whose median is outside them is flagged. A plot (PDF or PNG by the
file's suffix) and a CSV of the same numbers.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

MEDIAN_RANGE_2 = 0.954  # median range of two normal values, in sigmas
CONTROL_K = 3.0
COLUMNS = ("lot_id", "lot", "created", "items", "median", "iqr", "robust_sigma", "out_of_control")


def trend(db, quantity: str) -> tuple[list[dict], dict]:
    """(a row per lot that measured ``quantity``, the control limits {centre, sigma, low,
    high, note})."""
    from ares.batch import db as rdb
    from ares.batch.screens import robust_centre_sigma
    from ares.batch.vocabulary import canonical

    q = canonical(quantity)
    rows = []
    for lot in rdb.lots(db):
        v = rdb.values(db, lot["lot_id"], q)
        v = [x for x in v if math.isfinite(x)]
        if not v:
            continue
        med, sig = robust_centre_sigma(v)
        q25, q75 = np.percentile(v, [25, 75])
        rows.append({"lot_id": lot["lot_id"], "lot": lot["name"], "created": lot["created"], "items": len(v),
                     "median": med, "iqr": float(q75 - q25), "robust_sigma": sig})
    limits = {"centre": None, "sigma": None, "low": None, "high": None, "note": ""}
    meds = np.array([r["median"] for r in rows])
    if len(meds) >= 2:
        sigma = float(np.median(np.abs(np.diff(meds)))) / MEDIAN_RANGE_2
        centre = float(np.median(meds))
        limits.update(centre=centre, sigma=sigma, low=centre - CONTROL_K * sigma, high=centre + CONTROL_K * sigma)
    else:
        limits["note"] = f"{len(meds)} lot(s) measured {q}: control limits need at least 2"
    for r in rows:
        r["out_of_control"] = "" if limits["low"] is None else \
            ("yes" if not limits["low"] <= r["median"] <= limits["high"] else "no")
    return rows, limits


def to_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: repr(v) if isinstance(v, float) else v for k, v in r.items()})
    return buf.getvalue()


def plot(rows: list[dict], limits: dict, quantity: str, unit: str, path: Path) -> None:
    from matplotlib.figure import Figure

    from ares.batch.vocabulary import quantity_heading, quantity_label
    from ares.report.plots import RC

    import matplotlib

    with matplotlib.rc_context(RC):
        fig = Figure(figsize=(8.27, 5.0))
        ax = fig.add_axes([0.1, 0.18, 0.86, 0.72])
        x = np.arange(len(rows))
        med = np.array([r["median"] for r in rows])
        iqr = np.array([r["iqr"] for r in rows])
        ax.errorbar(x, med, yerr=iqr / 2, fmt="o", color="C0", capsize=3, label="lot median (bar: IQR)")
        bad = [i for i, r in enumerate(rows) if r["out_of_control"] == "yes"]
        if bad:
            ax.plot(x[bad], med[bad], "o", color="C3", ms=9, mfc="none", label="outside the control limits")
        if limits["centre"] is not None:
            ax.axhline(limits["centre"], color="0.3", lw=1, label=f"centre {limits['centre']:.5g}")
            for b in (limits["low"], limits["high"]):
                ax.axhline(b, color="C3", ls="--", lw=1)
            ax.plot([], [], color="C3", ls="--", label=f"control limits (+-{CONTROL_K:g} sigma, moving range)")
        ax.set_xticks(x, [r["lot"] for r in rows], rotation=45, ha="right", fontsize=7)
        ax.set(ylabel=quantity_heading(quantity, unit),
               title=f"{quantity_label(quantity)} per lot ({len(rows)} lot(s))"
               + (f" -- {limits['note']}" if limits["note"] else ""))
        ax.legend(fontsize=7)
        fig.savefig(path)
