"""``ares ptc``: photon transfer from a mean/variance table a user already has.

    ares ptc TABLE [--columns mean,var,...] [--pixels N] [--frames N] [--json] [--pdf FILE]

The same analysis as a scan's ``ptc`` (``ares.analysis.ptc.photon_transfer.analyze_ptc``): levels in
signal order whatever the row order, near-zero and non-finite rows dropped with a note,
the saturation bracket, the data-chosen gain model with its residual tests, the EMVA 1288
4.0 Eq. 51 local-slope check, every figure with its SE or "not available" and why. The
table format is in ``ares/hardware/ptc_table.py``; the report's ``ptc.csv`` is one.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ares.analysis.stats.estimate import format_dict
from ares.commands.argtypes import positive
from ares.errors import InputError

NAME = "ptc"
HELP = "photon transfer (gain, read noise, saturation, full well) from a mean/variance table"
UNKNOWN_PIXELS = 10**12  # no pixel counts: SEs from the fits' residual scatter (and the most a level may hold)
MAX_FRAMES = 10**9  # frames a level may average
# Every path of ``ares ptc`` is linear in the rows (issue 54; benchmarks/bench_ptc_rows.py:
# ~0.13 ms and ~4 kB a row). A photon-transfer table has tens to a few thousand levels;
# above this many rows (~30 s, ~1 GB) the table is refused before it is parsed.
MAX_ROWS = 200_000


def add_arguments(p) -> None:
    p.add_argument("table", help="CSV or whitespace table, one row per level (header names or --columns)")
    p.add_argument("--columns", default=None, metavar="F1,F2,...",
                   help="fields of the columns in order when the table has no header "
                        "(mean,var,dark_mean,dark_var,n_pixels,n_frames,exposure,photons,signal_se; - skips)")
    p.add_argument("--pixels", type=int, default=None, help="pixels per level when the table has no n_pixels column")
    p.add_argument("--frames", type=int, default=None,
                   help="frames per level when the table has no n_frames column (default 2: a pair)")
    p.add_argument("--adc-lsb-uv", type=positive, default=None, help="ADC LSB in uV (for the conversion gain in uV/e-)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--pdf", default=None, metavar="FILE", help="write the PTC, SNR and linearity plots to a PDF")


def _levels(table, pixels: int | None, frames: int | None):
    from ares.analysis.ptc.levels import LevelStats

    n = len(table)
    col = table.get
    notes = []
    if col("n_pixels") is None and pixels is None:
        notes.append("no pixel counts: the decisions (turnoff, gain model) use the levels' measured scatter and "
                     "the SEs come from the fits' residual scatter (--pixels gives the Gaussian variance errors, "
                     "still checked against that scatter)")
    if frames is None and col("n_frames") is None:
        notes.append("no frame counts: each level taken as a pair (--frames to change)")

    def val(name, i, default):
        c = col(name)
        return default if c is None or not math.isfinite(c[i]) else c[i]

    def count(name, i, default, lo, hi, what):  # a whole number lo .. hi, else one sentence naming the line
        x = val(name, i, default)
        if not (lo <= x <= hi and x == int(x)):
            raise InputError(f"{table.path}:{table.lines[i]}: {name} {x:g} is not a {what} "
                             f"(a whole number from {lo:g} to {hi:g})")
        return int(x)

    if col("dark_mean") is None and col("dark_var") is None:
        notes.append("no dark columns: the means and variances are taken as dark-subtracted; read noise needs them")
    bright, dark, seen = [], [], {}
    for i in range(n):
        npx = count("n_pixels", i, pixels if pixels is not None else UNKNOWN_PIXELS, 1, UNKNOWN_PIXELS, "pixel count")
        nfr = count("n_frames", i, frames if frames is not None else 2, 2, MAX_FRAMES, "frame count")
        bright.append(LevelStats(col("mean")[i], col("var")[i], npx, nfr, val("frac_at_max", i, 0.0)))
        key = (val("dark_mean", i, 0.0), val("dark_var", i, 0.0), npx,
               count("dark_n_frames", i, nfr, 2, MAX_FRAMES, "frame count"))
        if key not in seen:  # one dark level shared by many rows is one measurement
            seen[key] = LevelStats(*key)
        dark.append(seen[key])
    return bright, dark, notes


def _axis(table, name: str, notes: list[str]):
    c = table.get(name)
    if c is None:
        return None
    if not all(math.isfinite(x) for x in c):
        notes.append(f"the {name} column has empty or non-finite cells: not used")
        return None
    return list(c)


def _row_limit(path) -> None:
    """Refuse a table of more than ``MAX_ROWS`` lines before parsing it (one sentence)."""
    import os
    import stat

    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return  # (a fifo, a directory: the reader names it without reading)
        with open(path, "rb") as f:
            lines = sum(chunk.count(b"\n") for chunk in iter(lambda: f.read(1 << 20), b""))
    except OSError:
        return  # (the reader names the problem)
    if lines > MAX_ROWS + 1:
        raise InputError(f"{path}: {lines} lines; ares ptc takes at most {MAX_ROWS} rows (a photon-transfer table has "
                         "tens to thousands of levels: average or thin the rows first)")


def analyse_table(path: str | Path, columns: list[str] | None = None, pixels: int | None = None,
                  frames: int | None = None, adc_lsb_uv: float | None = None):
    """(PtcResult, JSON dict, level names) for a table file."""
    from ares.analysis.ptc.photon_transfer import analyze_ptc
    from ares.hardware.ptc_table import read_ptc_table

    _row_limit(path)
    table = read_ptc_table(path, columns)
    if len(table) < 2:
        raise InputError(f"{table.path}: one level is not a photon-transfer curve (needs >= 2 rows, "
                         f"best >= 10 from dark to saturation)")
    if table.get("var") is None:
        return _ramp(table)
    bright, dark, notes = _levels(table, pixels, frames)
    exposure = _axis(table, "exposure", notes)
    photons = _axis(table, "photons", notes)
    sse = table.get("signal_se")
    no_dark = table.get("dark_mean") is None and table.get("dark_var") is None
    r = analyze_ptc(bright, dark, exposure_s=exposure, photons=photons, adc_lsb_uv=adc_lsb_uv,
                    signal_se=list(sse) if sse is not None else None,
                    counts_known=table.get("n_pixels") is not None or pixels is not None)
    names = [f"line {ln}" for ln in table.lines]
    d = {"table": str(table.path), "levels": len(table)}
    d.update(r.to_dict(names))
    if no_dark:
        from ares.analysis.stats.estimate import Estimate

        why = Estimate.na("the table has no dark columns", "e-")
        d["read_noise_e"], d["read_noise_dn"] = why.to_dict(), Estimate.na(why.note, "DN").to_dict()
        d["sensitivity_threshold_e"] = why.to_dict()
        d["dynamic_range_db"] = Estimate.na(why.note, "dB").to_dict()
    d["notes"] = notes
    return r, d, names


def _ramp(table):
    """(None, JSON dict, level names) of a linearity ramp: signal against an illumination
    axis, no variances -- its linearity turnoff and maximum signal (``ramp.ramp_turnoff``,
    LSST cp_pipe's rule), every figure with its verdict."""
    import numpy as np

    from ares.analysis.ptc.ramp import ramp_turnoff
    from ares.analysis.stats.estimate import Estimate

    axis = next(a for a in ("monitor", "photons", "exposure") if table.get(a) is not None)
    x = np.asarray(table.get(axis), float)
    y = np.asarray(table.get("mean"), float)
    if table.get("dark_mean") is not None:
        y = y - np.nan_to_num(np.asarray(table.get("dark_mean"), float))
    r = ramp_turnoff(x, y)
    names = [f"line {ln}" for ln in table.lines]
    d = {"table": str(table.path), "levels": len(table), "ramp_axis": axis}
    if r.index < 0:
        to = mx = Estimate.na(r.note, "DN")
    else:
        nxt = np.sort(y[np.isfinite(y) & (y > r.turnoff)])
        se = (float(nxt[0]) - r.turnoff) / 3**0.5 if nxt.size else float("nan")
        to = (Estimate(r.turnoff, se, "DN", r.note + "; SE: spacing to the next level / sqrt(3)") if r.reached
              else Estimate.limit(r.turnoff, "lower", "DN", r.note))
        mx = (Estimate(r.max_signal, r.max_signal_se, "DN", "median of the levels within 1 % of the brightest; SE: "
                       "their own scatter (1.2533 SD / sqrt(n), Student's t), one level: the 1 % window / sqrt(3)")
              if r.reached else Estimate.limit(r.max_signal, "lower", "DN", r.note))
    d["linearity_turnoff_dn"] = to.to_dict()
    d["max_signal_dn"] = mx.to_dict()
    d["linearity_turnoff_level"] = names[r.index] if r.index >= 0 else None
    d["notes"] = [f"no variance column: a linearity ramp of the signal against {axis}; photon-transfer figures "
                  "(gain, read noise, full well) need the variances"]
    return None, d, names


def _text(d: dict) -> str:
    if "ramp_axis" in d:
        out = [f"linearity ramp of {d['table']} ({d['levels']} levels, signal against {d['ramp_axis']})",
               f"  linearity turnoff  {format_dict(d['linearity_turnoff_dn'], with_reason=True)}"
               + (f" ({d['linearity_turnoff_level']})" if d["linearity_turnoff_level"] else ""),
               f"  maximum signal     {format_dict(d['max_signal_dn'], with_reason=True)}"]
        out += [f"  note: {n}" for n in d["notes"]]
        return "\n".join(out) + "\n"
    out = [f"photon transfer of {d['table']} ({d['levels']} levels)"]
    from ares.labels import PTC_FIGURES

    w = max(len(label) for _, label in PTC_FIGURES)
    for key, label in PTC_FIGURES:
        out.append(f"  {label:<{w}} {format_dict(d.get(key), with_reason=True)}")
    for label, key, field in (("gain model", "gain_model", "reason"),
                              ("linearity (Eq. 51)", "linearity_check_text", "note"),
                              ("linearity (ARES option)", "linearity_check", "note"),
                              ("saturation", "saturation", "reason"),
                              ("decision errors", "decision_errors", "note")):
        if isinstance(d.get(key), dict):
            out.append(f"  {label:<{w}} {d[key][field]}")
    for n in d.get("notes", []):
        out.append(f"  note: {n}")
    dropped = [s for s in d["level_status"] if s["status"] == "excluded"]
    if dropped:
        out.append(f"  {len(dropped)} level(s) excluded:")
        out += [f"    {s['stage']}: {s['reason']}" for s in dropped]
    return "\n".join(out) + "\n"


def write_pdf(r, names: list[str], path: Path, title: str) -> None:
    from ares.report import plots

    rows = [{"signal_dn": lv.signal, "variance_dn2": lv.variance, "variance_se_dn2": lv.variance_se,
             "status": lv.status, "stage": names[lv.index], "reason": lv.reason,
             "photons": None if not math.isfinite(lv.photons) else lv.photons,
             "exposure_s": lv.exposure_s} for lv in r.levels]
    import matplotlib

    with matplotlib.rc_context(plots.RC):
        fig = plots.new_page("Photon transfer", title)
        notes = plots.ptc_variance(fig.add_axes([0.1, 0.56, 0.85, 0.36]), rows, r, "variance vs signal")
        plots.snr_curve(fig.add_axes([0.1, 0.16, 0.85, 0.32]), r, "signal-to-noise ratio")
        if notes:
            fig.text(0.1, 0.02, "\n".join(plots.clip(n, 140) for n in notes[:8]), fontsize=6, va="bottom")

        plots.save_pdf([fig], path, f"ARES photon transfer {title}", "ares ptc")


def run(args) -> int:
    from ares.safefile import output_file, writing

    if args.pdf:  # before the work (ares.safefile)
        output_file(args.pdf, "--pdf")
    cols = [c for c in args.columns.split(",")] if args.columns else None
    r, d, names = analyse_table(args.table, cols, args.pixels, args.frames, args.adc_lsb_uv)
    if args.pdf and r is None:
        raise InputError(f"{args.table}: --pdf draws the photon-transfer curve, which a ramp without variances has not")
    if args.pdf:
        with writing(args.pdf):
            write_pdf(r, names, Path(args.pdf), str(args.table))
    if args.json:
        print(json.dumps(d, indent=2, allow_nan=False))
    else:
        print(_text(d), end="")
    return 0
