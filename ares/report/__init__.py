"""Reports of a run directory, from the directory alone: CSV tables and a PDF.

- ``write_reports(run_dir, formats=("csv", "pdf"), out_dir=None) -> list[Path]``:
  ``ptc.csv``, ``components.csv``, ``key_figures.csv`` (the per-stage table is the
  runner's ``summary.csv``) and ``report.pdf``, written into the run directory (or
  ``out_dir``).
- ``key_figures(run_dir) -> dict``: ``{name: {label, value, se, unit, note, source}}``.

A partial run (stopped, failed, killed) is reported as far as it goes and says so; a
missing or unreadable run directory raises ``ares.errors.InputError`` naming the path.
"""

from __future__ import annotations

from pathlib import Path

from ares.report.source import Run, read_run

FORMATS = ("csv", "pdf")


def key_figures(run_dir) -> dict:
    from ares.report import tables

    return tables.compute_key_figures(read_run(run_dir))


def write_reports(run_dir, formats=FORMATS, out_dir=None, *, pdf_path=None, csv_dir=None) -> list[Path]:
    """Write the requested reports; returns the files written. ``pdf_path``/``csv_dir``
    override where the PDF / the CSV tables go (default: ``out_dir`` or the run dir)."""
    from ares.errors import InputError
    from ares.report import csv_export, pdf, tables

    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise InputError(f"unknown report format '{bad[0]}' (choose from {', '.join(FORMATS)})")
    run = read_run(run_dir)
    base = Path(out_dir) if out_dir is not None else run.dir
    groups = tables.ptc_groups(run)
    kf = tables.compute_key_figures(run, groups)
    out: list[Path] = []
    if "csv" in formats:
        out += csv_export.write_csv(run, Path(csv_dir) if csv_dir else base, groups, kf)
    if "pdf" in formats:
        p = Path(pdf_path) if pdf_path else base / "report.pdf"
        pdf.write_pdf(run, p, groups, kf)
        out.append(p)
    return out


__all__ = ["write_reports", "key_figures", "read_run", "Run", "FORMATS"]
