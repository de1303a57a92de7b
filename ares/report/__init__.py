"""Reports of a run directory, from the directory alone: CSV tables and a PDF.

- ``write_reports(run_dir, formats=("csv", "pdf"), out_dir=None) -> list[Path]``:
  ``ptc.csv``, ``components.csv``, ``key_figures.csv`` (the per-stage table is the
  runner's ``summary.csv``), ``report.pdf`` and -- with "hdf5" in ``formats`` --
  ``report.h5`` (the same tables, linking the run's results.h5), written into the run
  directory (or ``out_dir``); a scan with the ``emva4`` analysis also gets
  ``emva_datasheet.pdf``, ``emva_datasheet_general.pdf`` and ``emva_datasheet.csv``
  (EMVA 1288 Release 4.0).
- ``key_figures(run_dir) -> dict``: ``{name: {label, value, se, unit, note, source}}``.

A partial run (stopped, failed, killed) is reported as far as it goes and says so; a
missing or unreadable run directory raises ``ares.errors.InputError`` naming the path.

May import ``results``, ``rundir``, ``protocol``, ``sim``, ``hardware``, ``analysis`` and the base
modules; never ``scan``."""

from __future__ import annotations

from pathlib import Path

from ares.report.source import Run, read_run

FORMATS = ("csv", "pdf", "hdf5")
DEFAULT_FORMATS = ("csv", "pdf")


def key_figures(run_dir) -> dict:
    from ares.report import tables

    return tables.compute_key_figures(read_run(run_dir))


def write_reports(run_dir, formats=DEFAULT_FORMATS, out_dir=None, *, pdf_path=None, csv_dir=None,
                  h5_path=None, helper=None) -> list[Path]:
    """Write the requested reports ("csv", "pdf", "hdf5"); returns the files written.
    ``pdf_path``/``csv_dir``/``h5_path`` override where each goes (default: ``out_dir``
    or the run directory). ``helper``: a ``pdf_parts`` helper started earlier for this run
    directory (one is started here otherwise); it is ended here either way."""
    from ares.errors import InputError, interruption

    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise InputError(f"unknown report format '{bad[0]}' (choose from {', '.join(FORMATS)})")
    run = read_run(run_dir)
    if "pdf" in formats:  # a second process draws part of the PDF, from now on
        from ares.report import pdf_parts

        helper = helper or pdf_parts.start(run.dir)
        if helper is not None:
            p = _pdf_path(run, out_dir, pdf_path)
            helper.go(p.with_name(p.name + ".parts"))
    try:
        files = _write(run, formats, out_dir, pdf_path, csv_dir, h5_path, helper)
        from ares.rundir import manifest
        from ares.rundir.files import storage

        with storage(run.dir / manifest.MANIFEST):  # the reports inside the run directory, with their hashes
            manifest.record(run.dir, files)
        return files
    except BaseException as exc:  # a signal abandoned the reports, or an error: the helper ends now
        if helper is not None:
            helper.kill()
        sig = interruption(exc)
        if sig is not None and sig is not exc:  # a cleanup the signal broke raised over it: the
            raise sig from None  # signal is what happened (else the run reads done, reports "failed")
        raise
    finally:
        if helper is not None:
            helper.close()
            if helper.workdir is not None:  # (gone already unless the PDF failed before its merge)
                import shutil

                shutil.rmtree(helper.workdir, ignore_errors=True)


def _pdf_path(run, out_dir, pdf_path) -> Path:
    return Path(pdf_path) if pdf_path else (Path(out_dir) if out_dir is not None else run.dir) / "report.pdf"


def _write(run, formats, out_dir, pdf_path, csv_dir, h5_path, helper) -> list[Path]:
    from ares.report import csv_export, h5_export, pdf, pdf_parts, tables

    base = Path(out_dir) if out_dir is not None else run.dir
    groups = tables.ptc_groups(run)
    kf = tables.compute_key_figures(run, groups)
    out: list[Path] = []
    if "csv" in formats:
        out += csv_export.write_csv(run, Path(csv_dir) if csv_dir else base, groups, kf)
    if "hdf5" in formats:
        out.append(h5_export.write_h5(run, Path(h5_path) if h5_path else base / "report.h5", groups, kf))
    if "pdf" in formats:
        p = _pdf_path(run, out_dir, pdf_path)
        emva = pdf.emva_sheet(run)
        pdf_parts.write_pdf(run, p, groups, kf, emva, helper=helper)
        out.append(p)
        if emva is not None:  # the EMVA 1288 Release 4.0 datasheet on its own, next to the report
            from ares.report import datasheet

            ds = p.with_name("emva_datasheet.pdf")
            datasheet.write_datasheet(emva[0], ds, emva[1])
            out.append(ds)
            if emva[1] is not None:  # Release 4.0 General: its own datasheet
                dg = p.with_name("emva_datasheet_general.pdf")
                datasheet.write_datasheet(emva[0], dg, emva[1], "4.0-general")
                out.append(dg)
    return out


__all__ = ["write_reports", "key_figures", "read_run", "Run", "FORMATS", "DEFAULT_FORMATS"]
