"""A run's per-stage table, ``summary.csv``: one row per stage with its settings and components, every column named with its unit; written by the runner as stages end and rebuilt by the report."""

from __future__ import annotations



def summary_row(result: dict, units: dict[str, str]) -> dict:
    """A stage's row of ``summary.csv`` (the runner writes it as stages finish; a run
    directory without it gets it rebuilt by ``summary_rows``): settings and components
    named with their units (``exposure_s``, ``reg:sf_bias_v``, ``Ps_dn2``, ``Ps_se_dn2``,
    ``Pg_rel_var``: ``ares.labels.with_unit``; ``units`` from ``System.setting_units``); where
    the stage was decomposed without its defect pixels too, those components as
    ``Ps_masked_dn2`` ... and the count ``masked_pixels`` (all-pixel columns unsuffixed)."""
    from ares.labels import with_unit

    row = {"index": result["index"], "name": result["name"], "scene": result["scene"], "frames": result["frames"],
           "dark_frames": result.get("dark_frames", 0)}
    for k, v in result["settings"].items():
        row[with_unit(k, units.get(k, ""))] = v
    full = result["views"]["full"]
    row["mean_dn"] = full["level"]["mean_dn"]
    row["var_dn2"] = full["level"]["var_dn2"]
    if "dark_level" in full:
        row["dark_mean_dn"] = full["dark_level"]["mean_dn"]
        row["dark_var_dn2"] = full["dark_level"]["var_dn2"]
    for k, e in (full.get("components") or {}).items():
        unit = e.get("unit", "")
        row[with_unit(k, unit)] = e.get("value")
        row[with_unit(f"{k}_se", unit)] = e.get("se")
    if full.get("components_masked"):  # the same components with the defect pixels left out (Ps_masked_dn2 ...)
        row["masked_pixels"] = full.get("masked_pixels")
        for k, e in full["components_masked"].items():
            unit = e.get("unit", "")
            row[with_unit(f"{k}_masked", unit)] = e.get("value")
            row[with_unit(f"{k}_masked_se", unit)] = e.get("se")
            if e.get("verdict", "ok") != "ok":  # a bound (a mask too short for every class): said beside it
                row[f"{k}_masked_verdict"] = e["verdict"]
    return row


def summary_rows(run) -> tuple[list[dict], list[str]]:
    """The runner's per-stage table (its ``summary.csv`` layout), rebuilt from the stage
    results -- for a run directory written without CSV output."""
    units = run.setting_units
    rows = [summary_row(st, units) for st in run.stages]
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    return rows, cols
