"""Bins and outlier screens of a judged lot (``lot_report.judge`` did the static limits).

Dynamic limits (part-average testing, the automotive rule of AEC-Q001): for each ``<pat
quantity k>`` of the lot file, over the items that passed every static limit and have the
quantity, the robust mean (median) and robust sigma (interquartile range / 1.349, the IQR
of a unit normal) set the limits median +- k sigma (k = 6 unless declared); an item outside
fails the screen. Screens come after the static limits: an item already failed keeps its
static bin, and is "not tested" by the screen.

Bins (one hard and one soft bin per item, as a tester's handler sorts parts): declared in the
lot file's ``<bins>`` (``ares.protocol.lot``: hard bins with name and pass/fail, soft bins
with their hard bin, name and role; a limit or screen goes to the soft bin its
``soft_bin=`` names, else to the soft bin ``for="limit"`` / ``for="pat"``). Without
``<bins>``, the default:

============  =========  =====================================================
hard bin      soft bin   meaning
============  =========  =====================================================
1 (pass)      1          passed every limit and screen
2             limit's    failed a static limit (the first failed, in file order;
                         soft bin ``soft_bin=`` or 10 + the limit's number)
3             screen's   an outlier of a dynamic screen (``soft_bin=`` or 50 +
                         the screen's number)
4             99         could not be analysed
============  =========  =====================================================

Either way an item goes to the first failure's bin: could not be analysed, then the static
limits in file order, then the screens. Declared bins are all listed (with 0 items too);
default ones as they fill.

A lot without limits, screens or declared bins bins nothing (hard and soft bin empty): no item is judged.
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


def screen(j, pats=(), limit_bins=(), hard_bins=(), soft_bins=()) -> None:
    """Apply the dynamic screens ``pats`` to the judged lot ``j`` and bin every item: sets
    ``r["checks"][screen]``, ``r["passed"]``, ``r["hard_bin"]``, ``r["soft_bin"]``,
    ``j.yields[screen]``, ``j.screens`` (every static limit and dynamic screen with its
    limits and counts) and ``j.bins`` ({soft bin: {hard, hard_name, pass, name, count}});
    ``hard_bins``/``soft_bins``: the lot file's declared bins (none: the default, ``plan``)."""
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
    limit_names = [limit_text(lim) for lim in j.limits]
    pat_names = [pat_text(p) for p in pats]
    pl = plan(limit_names, pat_names, limit_bins, [p.soft_bin for p in pats], hard_bins, soft_bins)
    judged_at_all = bool(j.limits) or bool(pats) or pl["declared"]  # (declared bins: bin, limits or not)
    names = {sb: {**b, "count": 0} for sb, b in pl["soft"].items()} if pl["declared"] else {}
    for r in j.results:
        if not judged_at_all:
            r["hard_bin"] = r["soft_bin"] = None
            continue
        checks = r.get("checks") or {}
        if r.get("status") == "error":
            sb, why = pl["error"], "could not be analysed"
        elif (bad := next((n for n, k in enumerate(limit_names) if checks.get(k) is False), None)) is not None:
            sb, why = pl["limits"][bad], f"failed {limit_names[bad]}"
        elif (bad := next((n for n, k in enumerate(pat_names) if checks.get(k) is False), None)) is not None:
            sb, why = pl["pats"][bad], f"outlier: {pat_names[bad]}"
        else:
            sb, why = pl["pass"], "pass"
        hb = pl["soft"][sb]["hard"]
        r["hard_bin"], r["soft_bin"] = hb, sb
        r["passed"] = pl["hard"][hb]["pass"]
        e = names.setdefault(sb, {**pl["soft"][sb], "name": pl["soft"][sb]["name"] or why, "count": 0})
        e["count"] += 1
    j.bins = dict(sorted(names.items()))


DEFAULT_HARD = {HARD_PASS: ("pass", True), HARD_LIMIT: ("failed a static limit", False),
                HARD_SCREEN: ("outlier of a dynamic screen", False), HARD_ERROR: ("could not be analysed", False)}


def plan(limit_names, pat_names, limit_bins=(), pat_bins=(), hard_bins=(), soft_bins=()) -> dict:
    """Where every outcome goes: {"pass": soft bin, "error": soft bin, "limits": [soft bin of
    each limit], "pats": [of each screen], "soft": {soft bin: {hard, hard_name, pass, name}},
    "hard": {hard bin: {name, pass}}, "declared": bins from the lot file}. ``hard_bins`` /
    ``soft_bins``: ``ares.protocol.lot.HardBin`` / ``SoftBin`` (checked when the lot file was
    read); none: the default bins (a soft bin's name "" -- the first item's reason names it)."""
    limit_bins = list(limit_bins) + [None] * len(limit_names)
    pat_bins = list(pat_bins) + [None] * len(pat_names)
    if hard_bins:
        hard = {h.number: {"name": h.name, "pass": h.passed} for h in hard_bins}
        role = {b.role: b.number for b in soft_bins if b.role}
        soft = {b.number: {"hard": b.hard, "name": b.name} for b in soft_bins}
        lims = [b or role["limit"] for b in limit_bins[:len(limit_names)]]
        pats = [b or role["pat"] for b in pat_bins[:len(pat_names)]]
        pass_, error = role["pass"], role["error"]
    else:
        hard = {n: {"name": nm, "pass": ok} for n, (nm, ok) in DEFAULT_HARD.items()}
        lims = [b or 10 + n for n, b in enumerate(limit_bins[:len(limit_names)], 1)]
        pats = [b or 50 + n for n, b in enumerate(pat_bins[:len(pat_names)], 1)]
        pass_, error = SOFT_PASS, SOFT_ERROR
        soft = {SOFT_PASS: {"hard": HARD_PASS, "name": "pass"}, SOFT_ERROR: {"hard": HARD_ERROR, "name": ""}}
        for sb in lims:
            soft.setdefault(sb, {"hard": HARD_LIMIT, "name": ""})
        for sb in pats:
            soft.setdefault(sb, {"hard": HARD_SCREEN, "name": ""})
    for b in soft.values():
        b.update(hard_name=hard[b["hard"]]["name"], **{"pass": hard[b["hard"]]["pass"]})
    return {"pass": pass_, "error": error, "limits": lims, "pats": pats, "soft": soft, "hard": hard,
            "declared": bool(hard_bins)}
