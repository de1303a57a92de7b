"""Bins and outlier screens of a judged lot (``lot_report.judge`` did the static limits).

Dynamic limits (part-average testing, the automotive rule of AEC-Q001): for each ``<pat
quantity k>`` of the lot file, over the items that passed every static limit and have the
quantity, the robust mean (median) and robust sigma (interquartile range / 1.349, the IQR
of a unit normal) set the limits median +- k sigma (k = 6 unless declared); an item outside
fails the screen. Screens come after the static limits: an item already failed keeps its
static bin, and is "not tested" by the screen.

Bins (one hard and one soft bin per item, as a tester's handler sorts parts):

============  =========  =====================================================
hard bin      soft bin   meaning
============  =========  =====================================================
1             1          passed every limit and screen
2             limit's    failed a static limit (the first failed, in file order;
                         soft bin ``soft_bin=`` or 10 + the limit's number)
3             screen's   an outlier of a dynamic screen (``soft_bin=`` or 50 +
                         the screen's number)
4             99         could not be analysed
============  =========  =====================================================

A lot without limits or screens bins nothing (hard and soft bin empty): no item is judged.
"""

from __future__ import annotations

import numpy as np

HARD_PASS, HARD_LIMIT, HARD_SCREEN, HARD_ERROR = 1, 2, 3, 4
SOFT_PASS, SOFT_ERROR = 1, 99
IQR_PER_SIGMA = 1.3490  # interquartile range of a unit normal: 2 * 0.67449


def pat_text(p) -> str:
    from ares.batch.vocabulary import canonical

    return f"PAT {canonical(p.quantity)} median +- {p.k:g} robust sigma"


def robust_centre_sigma(values) -> tuple[float, float]:
    """Median and IQR / 1.349 (a normal's sigma; one outlier in many moves neither)."""
    a = np.asarray(values, float)
    q25, q50, q75 = np.percentile(a, [25, 50, 75])
    return float(q50), float((q75 - q25) / IQR_PER_SIGMA)


def _value(r: dict, quantity: str):
    from ares.batch.lot_report import find

    f = find(r.get("figures") or {}, quantity)
    v = None if f is None else f.get("value")
    return None if v is None or not np.isfinite(float(v)) else float(v)


def screen(j, pats=(), limit_bins=()) -> None:
    """Apply the dynamic screens ``pats`` to the judged lot ``j`` and bin every item: sets
    ``r["checks"][screen]``, ``r["passed"]``, ``r["hard_bin"]``, ``r["soft_bin"]``,
    ``j.yields[screen]``, ``j.screens`` (every static limit and dynamic screen with its
    limits and counts) and ``j.bins`` ({soft bin: {hard, name, count}})."""
    from ares.batch.lot_report import limit_text

    j.screens = []
    for lim in j.limits:
        k = limit_text(lim)
        a, b = j.yields[k]
        j.screens.append({"screen": k, "quantity": lim.quantity, "kind": "static", "low": lim.min, "high": lim.max,
                          "centre": None, "sigma": None, "k": None, "n_tested": b, "n_failed": b - a})
    static_ok = [r.get("status") != "error" and all(v is not False for v in (r.get("checks") or {}).values())
                 for r in j.results]
    for p in pats:
        name = pat_text(p)
        vals = [(i, _value(r, p.quantity)) for i, r in enumerate(j.results) if static_ok[i]]
        vals = [(i, v) for i, v in vals if v is not None]
        centre = sigma = lo = hi = None
        if len(vals) >= 4:  # (quartiles of fewer say nothing)
            centre, sigma = robust_centre_sigma([v for _, v in vals])
            lo, hi = centre - p.k * sigma, centre + p.k * sigma
        tested = dict(vals) if lo is not None else {}
        failed = 0
        for i, r in enumerate(j.results):
            v = tested.get(i)
            ok = None if v is None else bool(lo <= v <= hi)
            r.setdefault("checks", {})[name] = False if r.get("status") == "error" else ok
            failed += ok is False
        j.yields[name] = (sum(r["checks"][name] is True for r in j.results), len(j.results))
        j.screens.append({"screen": name, "quantity": p.quantity, "kind": "dynamic", "low": lo, "high": hi,
                          "centre": centre, "sigma": sigma, "k": p.k, "n_tested": len(tested), "n_failed": failed,
                          "note": "" if lo is not None else f"{len(vals)} item(s) passed the static limits and "
                                                            f"have {p.quantity}: at least 4 are needed"})
    names = {}
    limit_names = [limit_text(lim) for lim in j.limits]
    limit_soft = [b or 10 + n for n, b in enumerate(list(limit_bins) + [None] * len(j.limits), 1)][:len(j.limits)]
    pat_names = [pat_text(p) for p in pats]
    pat_soft = [p.soft_bin or 50 + n for n, p in enumerate(pats, 1)]
    judged_at_all = bool(j.limits) or bool(pats)
    for r in j.results:
        if not judged_at_all:
            r["hard_bin"] = r["soft_bin"] = None
            continue
        checks = r.get("checks") or {}
        if r.get("status") == "error":
            hb, sb, nm = HARD_ERROR, SOFT_ERROR, "could not be analysed"
        elif (bad := next((n for n, k in enumerate(limit_names) if checks.get(k) is False), None)) is not None:
            hb, sb, nm = HARD_LIMIT, limit_soft[bad], f"failed {limit_names[bad]}"
        elif (bad := next((n for n, k in enumerate(pat_names) if checks.get(k) is False), None)) is not None:
            hb, sb, nm = HARD_SCREEN, pat_soft[bad], f"outlier: {pat_names[bad]}"
        else:
            hb, sb, nm = HARD_PASS, SOFT_PASS, "pass"
        r["hard_bin"], r["soft_bin"] = hb, sb
        r["passed"] = hb == HARD_PASS
        e = names.setdefault(sb, {"hard": hb, "name": nm, "count": 0})
        e["count"] += 1
    j.bins = dict(sorted(names.items()))
