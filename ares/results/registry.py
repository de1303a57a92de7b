"""The scan-level analyses by name (``register_scan_analysis``, ``scan_level_results``), the PTC's
choice of masked or all-pixel statistics, gains compared, and a scan's limits checked against
the results (``check_limits``, ``limits_verdict``)."""

from __future__ import annotations

import math
from typing import Callable

from ares.analysis.stats.estimate import VERDICT_LOWER, VERDICT_UPPER


# ------------------------------------------------------------ scan-level analyses

SCAN_ANALYSES: dict[str, Callable] = {}


def register_scan_analysis(name: str):
    """Decorator: ``fn(run) -> dict`` runs when a scan lists ``<analysis name=...>``.

    ``run`` is an :class:`ares.rundir.record.RunRecord` (scan, system, stage results,
    arrays loader), so the same function works live and from a run directory alone.
    """

    def deco(fn):
        SCAN_ANALYSES[name] = fn
        return fn

    return deco


def scan_level_results(run) -> dict:
    """Call every registered analysis the scan asks for; a missing one says so."""
    out = {}
    for name in run.scan.analyses:
        fn = SCAN_ANALYSES.get(name)
        if fn is None:
            out[name] = {"status": "not available", "note": f"no scan-level analysis registered for '{name}'"}
            continue
        try:
            out[name] = fn(run)
        except Exception as exc:  # an analysis bug must not lose the run: record it
            out[name] = {"status": "error", "note": f"{type(exc).__name__}: {exc}"}
    compare_gains(out)
    return out


def compare_gains(out: dict) -> None:
    """A scan with both ``ptc`` and ``emva4``: the photon transfer's ``gain_headline`` gets
    the EMVA 1288 4.0 Eq. 50 K beside it and one sentence saying which is the headline, why
    and how far apart they are (``ares.analysis.ptc.gain_compare``) -- the report, the terminal
    and the datasheet all show that sentence."""
    from ares.analysis.stats.estimate import Estimate
    from ares.analysis.ptc.gain_compare import k_statement

    ptc, e4 = out.get("ptc"), out.get("emva4")
    if not (isinstance(ptc, dict) and isinstance(e4, dict) and isinstance(ptc.get("gain_headline"), dict)):
        return
    k4 = (e4.get("values") or {}).get("K")
    if not isinstance(k4, dict) or not isinstance(ptc.get("gain_dn_per_e"), dict):
        return
    head = ptc["gain_headline"]
    chi2 = (ptc.get("gain_model") or {}).get("line_chi2_red")
    ptc["gain_headline"] = {**head, **k_statement(Estimate.from_dict(ptc["gain_dn_per_e"]), head.get("estimator"),
                                                  head.get("reason", ""), Estimate.from_dict(k4),
                                                  chi2 if isinstance(chi2, (int, float)) else math.nan)}


def leaves(results: dict, prefix: str = ""):
    """``(dotted key, leaf)`` for every estimate dict (``{"value": ...}``) and bare number
    in nested results -- what limits and precision targets name."""
    for k, v in results.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and "value" in v and not isinstance(v["value"], dict):
            yield key, v
        elif isinstance(v, dict):
            yield from leaves(v, key + ".")
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            yield key, v


def flatten(results: dict, prefix: str = "") -> dict[str, float]:
    """``{"ptc": {"read_noise_e": {"value": 3}}}`` -> ``{"ptc.read_noise_e": 3, ...}``."""
    return {k: (v["value"] if isinstance(v, dict) else v) for k, v in leaves(results, prefix)}


def find_estimate(results: dict, quantity: str) -> dict | None:
    """The ``{"value", "se", ...}`` dict ``quantity`` names (first match, as a limit finds
    its value), or None."""
    return next((v for k, v in leaves(results) if isinstance(v, dict) and names_quantity(k, quantity)), None)


def names_quantity(key: str, quantity: str) -> bool:
    """Does a limit's ``quantity`` name the flattened result ``key``? Its last part is the
    key's leaf and its other parts appear in the key's path in order (``read_noise_e``,
    ``ptc.read_noise_e``, ``decomposition.Pt`` for ``decomposition.components.Pt``)."""
    k, q = key.split("."), quantity.split(".")
    if k[-1] != q[-1]:
        return False
    it = iter(k[:-1])
    return all(part in it for part in q[:-1])


def limits_verdict(status: str, n_limits: int, fails) -> dict:
    """What the run says about its limits, the same on every surface (terminal, run JSON,
    report): ``state`` is "none set" (the scan sets none), "not checked" (the run did not
    finish: nothing was checked), "failed" or "passed"; ``text`` the one line shown."""
    fails = list(fails or [])
    if n_limits == 0:
        state, text = "none set", "limits: none set (the scan sets no limits)"
    elif fails:
        state, text = "failed", f"limits: {len(fails)} of {n_limits} failed -- " + "; ".join(fails)
    elif status != "done":
        state, text = "not checked", f"limits: not checked (the run is {status}; {n_limits} limit(s) set)"
    else:
        state, text = "passed", f"limits: all {n_limits} passed"
    return {"state": state, "text": text, "n_limits": n_limits}


def limit_passes(lim, leaf) -> bool | None:
    """Does the figure ``leaf`` (an estimate dict or a bare number) meet the limit ``lim``? None
    when it has no value; a figure known only as a limit passes only where the limit proves it
    (an upper limit below the maximum with no minimum set, a lower one above the minimum with
    no maximum set): never a wrong pass by comparing a limit as if it were measured."""
    v = leaf.get("value") if isinstance(leaf, dict) else leaf
    if v is None:
        return None
    bound = limit_side(leaf)
    if not lim.check(float(v)):
        return False
    return not ((bound == "upper" and lim.min is not None) or (bound == "lower" and lim.max is not None))


def limit_side(leaf) -> str:
    """"upper" or "lower" where an estimate dict is only a limit, else ""."""
    return {VERDICT_UPPER: "upper", VERDICT_LOWER: "lower"}.get(leaf.get("verdict", ""), "") if isinstance(leaf, dict) else ""


def check_limits(scan, results: dict) -> list[str]:
    """One sentence per failed limit; a quantity no analysis produced fails too."""
    fails = []
    for lim in scan.limits:
        hits = [leaf for k, leaf in leaves(results) if names_quantity(k, lim.quantity)]
        if not hits:
            fails.append(f"limit on '{lim.quantity}': no analysis produced this quantity")
            continue
        leaf = hits[0]
        v, bound = (leaf["value"] if isinstance(leaf, dict) else leaf), limit_side(leaf)
        if v is None or not lim.check(float(v)):
            shown = "n/a" if v is None else {"upper": "< ", "lower": "> "}.get(bound, "") + format(float(v), ".4g")
            fails.append(f"{lim.quantity} = {shown} is not {lim.bounds()}")
        elif not limit_passes(lim, leaf):  # only a limit is known: inside the range, the value may not be
            fails.append(f"{lim.quantity}: only {'an upper' if bound == 'upper' else 'a lower'} limit is known "
                         f"({'<' if bound == 'upper' else '>'} {float(v):.4g}), which cannot show it is {lim.bounds()}")
    return fails


def ptc_level_keys(stages: list[dict]) -> tuple[str, str]:
    """The stage-level statistics a PTC uses: over the good pixels of the run's defect mask
    when every level has them (``level_masked``/``dark_level_masked``), else all pixels."""
    ok = all("level_masked" in s["views"]["full"] and "dark_level_masked" in s["views"]["full"] for s in stages)
    return ("level_masked", "dark_level_masked") if ok and stages else ("level", "dark_level")
