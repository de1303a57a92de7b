"""Pieces every report page of a scan kind uses: whether the run has an analysis, its figures as table rows, and the table drawn on a figure."""

from __future__ import annotations

from ares.report.plots import text_table
import math
from ares.analysis.stats.estimate import Estimate, format_value


def available(run, name: str) -> dict | None:
    a = run.analyses.get(name)
    if not isinstance(a, dict) or a.get("status") in ("not available", "error"):
        return None
    return a


def analysis_rows(a: dict, prefix: str = "", skip_na: bool = False) -> list[list[str]]:
    """Every estimate and scalar of an analysis result as [quantity, value ± SE, note]."""
    rows = []
    for k, v in a.items():
        key = f"{prefix}{k}"
        if k in ("by_temperature", "cycles", "channels") and isinstance(v, dict):
            rows += analysis_rows(v, prefix, skip_na)
        elif isinstance(v, dict) and "value" in v and "unit" in v:
            if skip_na and v.get("value") is None:
                continue
            rows.append([key, fmt_value(v.get("value"), v.get("se"), v.get("unit", ""), v.get("verdict", ""),
                                        v.get("exact", "")),
                         v.get("note", "")])
        elif isinstance(v, dict) and k == "settings":
            rows.append([key, ", ".join(f"{a_.removeprefix('reg:')}={b}" for a_, b in v.items()), ""])
        elif isinstance(v, dict):
            rows += analysis_rows(v, key + " / ", skip_na)
        elif isinstance(v, bool) or isinstance(v, str) or v is None:
            if k not in ("status", "note"):
                rows.append([key, "n/a" if v is None else str(v), ""])
        elif isinstance(v, (int, float)):  # counts and fit statistics (chi2/dof), not measured figures
            rows.append([key, f"{v:.4g}", ""])
        elif isinstance(v, list) and len(v) <= 12:
            rows.append([key, ", ".join(f"{x:.4g}" if isinstance(x, float) else str(x) for x in v), ""])
    return rows


def _table(fig, y: float, rows, title: str = "", n: int = 30) -> float:
    if not rows:
        return y
    return text_table(fig, (0.06, y, 0.9), ["quantity", "value ± SE", "note"], rows[:n], [0.36, 0.3, 0.34],
                      fontsize=7.5, title=title, max_chars=[46, 38, 46]) - 0.02


ANALYSIS_LABELS = {
    "rate_e_per_s": "dark current", "rate_dn_per_s": "dark current", "offset_dn": "dark offset at t = 0",
    "rate_from_variance_e_per_s": "dark current from dark variance", "dsnu_dn_per_s": "DSNU growth",
    "offset_drift_dn_per_s": "dark offset drift with clock time",
    "dsnu_e_per_s": "DSNU growth", "doubling_temperature_c": "dark current doubling temperature",
    "rate_at_ref_dn_per_s": "dark current at the reference temperature",
    "rate_at_ref_e_per_s": "dark current at the reference temperature", "pixel_noise_e": "pixel noise (gain split)",
    "chain_noise_dn": "chain noise (gain split)", "crossover_gain_dn_per_e": "crossover gain (gain split)",
    "lag_pct": "image lag", "dnl_max_lsb": "DNL max", "dnl_min_lsb": "DNL min", "inl_max_lsb": "INL max",
    "inl_min_lsb": "INL min", "qe": "quantum efficiency", "mu_p": "photons per pixel mu_p",
    "net_signal_dn": "net signal mu_y - mu_y.dark", "gain_dn_per_e": "system gain K (photon transfer)",
    "mtf50_cy_per_px": "MTF50", "mtf_at_nyquist": "MTF at Nyquist", "angle_deg": "edge angle",
}


_PATH_NOISE = ("by_temperature", "cycles", "channels", "values", "points", "stages")


def analysis_label(aname: str, key: str) -> str:
    """``dark_current`` + ``by_temperature.40C.rate_e_per_s`` -> ``dark current (40C)``;
    ``emva4`` + ``values.sigma_d`` -> ``EMVA 1288 4.0 σd`` (the standard's symbols)."""
    parts = key.split(".")
    where = [p for p in parts[:-1] if p not in _PATH_NOISE]
    if aname == "emva4":
        from ares.analysis.emva.sheet import symbol

        general = where[:1] == ["general"]
        return f"EMVA 1288 4.0 {'General ' if general else ''}{symbol(parts[-1], general)}"
    if aname == "emva1288":  # the older release's figures, named as such beside the 4.0 ones
        return f"EMVA 1288 3.0 {parts[-1]}" + (f" ({' '.join(where)})" if where else "")
    base = ANALYSIS_LABELS.get(parts[-1], f"{aname}: {parts[-1]}")
    return base + (f" ({' '.join(where)})" if where else "")


def fmt_value(v, se=None, unit: str = "", verdict: str = "", exact: str = "") -> str:
    """``value ± se unit`` with the digits the SE supports (``ares.analysis.stats.estimate``); a
    limit (``verdict`` "upper limit"/"lower limit") as ``< x``/``> x``; an SE of exactly 0 with
    its verdict, ``x unit (exact: why)`` (``exact``: the why) -- as every other surface."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    bound = {"upper limit": "upper", "lower limit": "lower"}.get(verdict, "")
    if bound:
        return Estimate(float(v), math.nan, unit, "", bound).text()
    if se is not None and se == 0:
        return Estimate(float(v), 0.0, unit, "", "", exact).text()
    return format_value(v, se) + (f" {unit}" if unit else "")
