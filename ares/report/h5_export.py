"""HDF5 export of the report tables: ``report.h5``.

Layout: ``/key_figures``, ``/ptc``, ``/components``, ``/levels`` (and ``/adc_inl_dnl``,
``/spectral_qe`` when the scan ran those analyses) -- one group per table, one 1-D
dataset per column (float64, or UTF-8 strings), attribute ``columns`` giving the order;
root attributes ``run`` (run.json) and ``scan_results`` (scan_results.json) as JSON;
``/stages`` links to the run's own ``results.h5`` per-stage arrays (an HDF5 external
link, relative when the file sits in the run directory).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from ares.report import tables
from ares.report.csv_export import KEY_FIGURE_COLUMNS, key_figure_rows
from ares.report import series_tables


def _column(values: list):
    nums = [v for v in values if v is not None and not isinstance(v, str)]
    if len(nums) == len([v for v in values if v is not None]) and not any(isinstance(v, bool) for v in nums):
        return np.array([math.nan if v is None else float(v) for v in values], dtype=np.float64)
    import h5py

    return np.array(["" if v is None else str(v) for v in values], dtype=h5py.string_dtype())


def _table(group, rows: list[dict], columns) -> None:
    """One dataset per column, each with its unit (attribute ``unit``: from the column's name,
    ``ares.labels``; a table with a ``unit`` column says so for its ``value`` and ``se``)."""
    from ares.labels import unit_of_column

    group.attrs["columns"] = json.dumps(list(columns))
    for c in columns:
        ds = group.create_dataset(c, data=_column([r.get(c) for r in rows]))
        unit = unit_of_column(c)
        if c in ("value", "se") and "unit" in columns:
            unit = "per row: the 'unit' column"
        if unit:
            ds.attrs["unit"] = unit


def write_h5(run, path: str | Path, groups=None, kf=None) -> Path:
    import h5py

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    groups = tables.ptc_groups(run) if groups is None else groups
    kf = tables.compute_key_figures(run, groups) if kf is None else kf
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs["format"] = "ares-report/1"
        f.attrs["run"] = json.dumps(run.meta)
        f.attrs["complete"] = run.complete
        f.attrs["note"] = run.incompleteness()
        f.attrs["scan_results"] = json.dumps(run.scan_results) if run.scan_results is not None else ""
        if run.attribution:
            f.attrs["attribution"] = run.attribution
        _table(f.create_group("key_figures"), [dict(r) for r in key_figure_rows(kf)], KEY_FIGURE_COLUMNS)
        _table(f.create_group("ptc"), *tables.ptc_export(run, groups))
        _table(f.create_group("components"), [r for st in run.stages for r in tables.component_rows(st)],
               tables.COMPONENT_COLUMNS)
        _table(f.create_group("levels"), [r for st in run.stages for r in tables.level_rows(st)],
               tables.LEVEL_COLUMNS)
        adc = series_tables.adc_rows(run)
        if adc:
            _table(g := f.create_group("adc_inl_dnl"), adc, series_tables.ADC_COLUMNS)
            g.attrs["se_note"] = json.dumps(series_tables.adc_se_notes(run))  # channel -> how the SEs were made
        sq = run.analyses.get("spectral_qe")
        if isinstance(sq, dict) and "points" in sq:  # QE(lambda): the same rows as spectral_qe.csv
            from ares.report.spectral_qe_page import SPECTRAL_COLUMNS, spectral_csv_rows

            _table(f.create_group("spectral_qe"), spectral_csv_rows(sq), SPECTRAL_COLUMNS)
        if run.has_h5:
            target = run.dir / "results.h5"
            same_dir = path.parent.resolve() == run.dir.resolve()
            f["stages"] = h5py.ExternalLink(os.path.relpath(target, path.parent) if same_dir else str(target.resolve()),
                                            "/stages")
    tmp.replace(path)
    return path
