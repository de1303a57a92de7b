"""CSV export of a run directory: ``ptc.csv``, ``components.csv``, ``levels.csv``,
``key_figures.csv``.

The per-stage table is the runner's ``summary.csv`` (view "full"): copied when the tables
go elsewhere, rebuilt in the same layout when the run wrote none;
``levels.csv`` adds what it leaves out: every view, spatial variance, clip fractions, the
matched dark's statistics and the stage duration. Floats are
written with ``repr`` (round-trip exact); a value that is not available is empty.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from ares.analysis.stats.estimate import note_text
from ares.report import tables
from ares.rundir.summary import summary_rows
from ares.report import series_tables

KEY_FIGURE_COLUMNS = ("name", "label", "value", "se", "unit", "verdict", "note", "source")


def _cell(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(float(v)) if math.isfinite(v) else ""
    return v


def to_csv(rows: list[dict], columns) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({k: _cell(r.get(k)) for k in columns})
    return buf.getvalue()


def _write(path: Path, text: str) -> Path:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)
    return path


def key_figure_rows(kf: dict) -> list[dict]:
    """key_figures.csv / report.h5 rows; an exact figure's note starts with its verdict (``note_text``)."""
    return [dict(name=k, **{**v, "note": note_text(v)}) for k, v in kf.items()]


def write_csv(run, out_dir: str | Path, groups=None, kf=None) -> list[Path]:
    """Write the three tables into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    groups = tables.ptc_groups(run) if groups is None else groups
    kf = tables.compute_key_figures(run, groups) if kf is None else kf
    comp = [r for st in run.stages for r in tables.component_rows(st)]
    extra = []
    summary = run.dir / "summary.csv"
    if out.resolve() != run.dir.resolve() or not summary.exists():
        # the CSV set is complete where it is written: the runner's per-stage table too
        if summary.exists():
            extra.append(_write(out / "summary.csv", summary.read_text()))
        elif run.stages:
            extra.append(_write(out / "summary.csv", to_csv(*summary_rows(run))))
    return extra + [
        _write(out / "ptc.csv", to_csv(*tables.ptc_export(run, groups))),
        _write(out / "components.csv", to_csv(comp, tables.COMPONENT_COLUMNS)),
        _write(out / "levels.csv", to_csv([r for st in run.stages for r in tables.level_rows(st)],
                                          tables.LEVEL_COLUMNS)),
        _write(out / "key_figures.csv", to_csv(key_figure_rows(kf), KEY_FIGURE_COLUMNS)),
    ] + _emva_csv(run, out) + _adc_csv(run, out) + _mtf_csv(run, out) + _spectral_csv(run, out)


def _adc_csv(run, out: Path) -> list[Path]:
    """``adc_inl_dnl.csv``: every code's DNL and every transition's INL with their counting
    SEs, per channel, when the scan ran the ``adc_linearity`` analysis."""
    rows = series_tables.adc_rows(run)
    return [_write(out / "adc_inl_dnl.csv", to_csv(rows, series_tables.ADC_COLUMNS))] if rows else []


def _mtf_csv(run, out: Path) -> list[Path]:
    """``mtf.csv`` when the scan ran the ``mtf`` analysis (ares.report.mtf_page)."""
    a = run.analyses.get("mtf")
    if not isinstance(a, dict) or "stages" not in a:
        return []
    from ares.report.mtf_page import MTF_COLUMNS, mtf_csv_rows

    return [_write(out / "mtf.csv", to_csv(mtf_csv_rows(a), MTF_COLUMNS))]


def _spectral_csv(run, out: Path) -> list[Path]:
    """``spectral_qe.csv`` when the scan ran the ``spectral_qe`` analysis (ares.report.spectral_qe_page)."""
    a = run.analyses.get("spectral_qe")
    if not isinstance(a, dict) or "points" not in a:
        return []
    from ares.report.spectral_qe_page import SPECTRAL_COLUMNS, spectral_csv_rows

    return [_write(out / "spectral_qe.csv", to_csv(spectral_csv_rows(a), SPECTRAL_COLUMNS))]


EMVA_COLUMNS = ("release", "quantity", "symbol", "value", "se", "unit", "verdict", "definition")


def _emva_csv(run, out: Path) -> list[Path]:
    """``emva_datasheet.csv``: the EMVA 1288 Release 4.0 Linear and General values with the
    standard's quantity names and units, when the scan ran the ``emva4`` analysis."""
    a = run.analyses.get("emva4")
    if not isinstance(a, dict) or "values" not in a:
        return []
    from ares.analysis.emva.sheet import symbol

    rows = []
    for rel, vals, general in ((a.get("release", ""), a["values"], False),
                               ((a.get("general") or {}).get("release", ""), (a.get("general") or {}).get("values") or {},
                                True)):
        for k, v in vals.items():  # (each under its table's symbol: the General one's own, µp.sat.area)
            rows.append({"release": rel, "quantity": k, "symbol": v.get("symbol") or symbol(k, general), "value": v.get("value"),
                         "se": v.get("se"), "unit": v.get("unit", ""), "verdict": v.get("verdict", ""),
                         "definition": note_text(v)})
    return [_write(out / "emva_datasheet.csv", to_csv(rows, EMVA_COLUMNS))]
