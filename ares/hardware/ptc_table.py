"""Photon-transfer tables a user already has: one row per illumination level.

CSV (comma, semicolon or tab) or whitespace-separated text, ``#`` comments, an optional
header. Columns are found by header name (case-insensitive, first match of each alias
list wins) or given in order with ``columns=`` (``ares ptc --columns``):

===============  =================================================  =========
field            header names                                       needed
===============  =================================================  =========
``mean``         mean, mean_dn, mu, mu_y, mean_adu, raw_mean_adu   yes
``var``          var, variance, bright_variance_dn2, var_dn2, s2_y  yes
``dark_mean``    dark_mean, dark_mean_dn, mu_dark, mu_y_dark        no (0)
``dark_var``     dark_var, dark_variance_dn2, s2_dark, s2_y_dark    no (0)
``n_pixels``     n_pixels, pixels, npix                             no
``n_frames``     n_frames, frames                                   no (2)
``dark_n_frames``  dark_n_frames, dark_frames                       no (n_frames)
``frac_at_max``  frac_at_max, clipped_fraction (samples at max code) no (0)
``exposure``     exposure, exposure_s, t_exp, texp                  no
``photons``      photons, mu_p, photons_per_pixel                   no
``signal_se``    signal_se, signal_se_dn                            no
``monitor``      monitor, photo_charge, photo_charge_c, pd_charge   no
===============  =================================================  =========

A table without ``var`` but with an illumination column (``exposure``, ``photons`` or
``monitor``, a monitor-photodiode charge in any unit) is a linearity ramp.
The report's ``ptc.csv`` (``ares report``) is such a table. Variances are *raw* (bright
and dark apart); without pixel counts the standard errors come from the fits' residual
scatter. Rows whose numbers are empty or not finite are kept and reported by the analysis
as excluded, with the reason; a malformed row, or a value beyond what a measurement holds
(``BOUNDS``: a unit slip, a corrupt export), is one sentence naming the file and line.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

from ares.analysis.noise.accumulate import MAX_DN
from ares.errors import InputError
from ares.safefile import read_regular

MAX_BYTES = 64 * 1024 * 1024
ALIASES = {
    "mean": ("mean", "mean_dn", "mu", "mu_y", "mean_adu", "raw_mean_adu"),
    "var": ("var", "variance", "bright_variance_dn2", "var_dn2", "s2_y"),
    "dark_mean": ("dark_mean", "dark_mean_dn", "mu_dark", "mu_y_dark"),
    "dark_var": ("dark_var", "dark_variance_dn2", "s2_dark", "s2_y_dark"),
    "n_pixels": ("n_pixels", "pixels", "npix"),
    "n_frames": ("n_frames", "frames"),
    "dark_n_frames": ("dark_n_frames", "dark_frames"),
    "frac_at_max": ("frac_at_max", "clipped_fraction"),
    "exposure": ("exposure", "exposure_s", "t_exp", "texp"),
    "photons": ("photons", "mu_p", "photons_per_pixel"),
    "signal_se": ("signal_se", "signal_se_dn"),
    "monitor": ("monitor", "photo_charge", "photo_charge_c", "pd_charge"),
}
REQUIRED = ("mean", "var")
# what a measurement can hold (a 40-bit ADC's DN and their squares, a day's exposure ...):
# a finite value beyond is a unit slip or a corrupt export, named at its line; counts are
# checked by ``ares ptc`` (its --pixels/--frames fill them in)
_DN, _DN2 = MAX_DN, MAX_DN**2
BOUNDS = {"mean": (-_DN, _DN, "DN"), "dark_mean": (-_DN, _DN, "DN"), "var": (-_DN2, _DN2, "DN^2"),
          "dark_var": (-_DN2, _DN2, "DN^2"), "frac_at_max": (0.0, 1.0, ""), "exposure": (0.0, 1e6, "s"),
          "photons": (0.0, 1e15, "photons"), "signal_se": (0.0, _DN, "DN"), "monitor": (0.0, 1e15, "")}


@dataclass
class PtcTable:
    path: Path
    columns: dict[str, list[float]]  # field -> one value per row (NaN where empty)
    lines: list[int]  # source line of each row
    notes: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.lines)

    def get(self, name: str) -> list[float] | None:
        return self.columns.get(name)


def _read_text(path: Path) -> str:
    raw = read_regular(path, MAX_BYTES, "PTC table")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text table (not UTF-8)") from None


def _split(line: str, delim: str | None, path: Path | None = None, lineno: int = 0) -> list[str]:
    if delim is None:
        return line.split()
    try:
        return next(csv.reader(io.StringIO(line), delimiter=delim))
    except csv.Error:  # a field over the CSV parser's limit (or a broken quote): content never echoed
        raise InputError(f"{path}:{lineno}: a field is longer than {csv.field_size_limit()} characters (the CSV "
                         "parser's field limit) or badly quoted; not a PTC table") from None


def _number(text: str, path: Path, lineno: int, col: str) -> float:
    """The cell's value; NaN where empty or not finite (the level is then excluded, with
    the reason); one sentence for text or a value beyond ``BOUNDS``."""
    t = text.strip()
    if t == "" or t.lower() in ("nan", "na", "n/a", "none", "null"):
        return math.nan
    try:
        x = float(t)
    except ValueError:
        raise InputError(f"{path}:{lineno}: column '{col}' is not a number") from None  # content never echoed
    if not math.isfinite(x):
        return math.nan
    lo, hi, unit = BOUNDS.get(col, (-math.inf, math.inf, ""))
    if not lo <= x <= hi:
        raise InputError(f"{path}:{lineno}: column '{col}' = {x:g}{' ' + unit if unit else ''} is outside what a "
                         f"measurement holds ({lo:g} .. {hi:g})")
    return x


def read_ptc_table(path: str | Path, columns: list[str] | None = None) -> PtcTable:
    """Parse ``path``; ``columns`` names the fields of each column in order (``-`` or any
    unknown name skips a column) and then every line is data."""
    path = Path(path)
    text = _read_text(path)
    rows = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if not rows:
        raise InputError(f"{path}: the table has no rows")
    first = rows[0][1]
    delim = next((d for d in (",", ";", "\t") if d in first), None)
    header_cells = [c.strip().lower() for c in _split(first, delim, path, rows[0][0])]
    has_header = columns is None and any(_is_word(c) for c in header_cells)
    if columns is not None:
        names = [c.strip().lower() for c in columns]
        unknown = [c for c in names if c not in ALIASES and c != "-"]
        if unknown:
            raise InputError(f"--columns: unknown field(s) {', '.join(unknown)}; known: {', '.join(ALIASES)} "
                             "(or - to skip a column)")
        index = {n: i for i, n in enumerate(names) if n in ALIASES}
    elif has_header:
        index = {}
        for fld, alias in ALIASES.items():
            for a in alias:
                if a in header_cells:
                    index[fld] = header_cells.index(a)
                    break
        rows = rows[1:]
    else:
        raise InputError(f"{path}:{rows[0][0]}: no header row; name the columns with --columns "
                         f"(e.g. --columns mean,var,dark_mean,dark_var)")
    # a linearity ramp (mean against exposure or monitor charge) needs no variance column
    ramp = any(f in index for f in ("exposure", "photons", "monitor"))
    missing = [f for f in REQUIRED if f not in index and not (f == "var" and ramp)]
    if missing:
        raise InputError(f"{path}: no column for {', '.join(missing)} (header names: "
                         + "; ".join(f"{f}: {', '.join(ALIASES[f])}" for f in missing) + ")")
    if not rows:
        raise InputError(f"{path}: the table has a header but no data rows")
    cols: dict[str, list[float]] = {f: [] for f in index}
    lines = []
    width = max(index.values()) + 1
    for lineno, ln in rows:
        cells = _split(ln, delim, path, lineno)
        if len(cells) < width:
            raise InputError(f"{path}:{lineno}: {len(cells)} column(s), the table needs at least {width}")
        for f, i in index.items():
            cols[f].append(_number(cells[i], path, lineno, f))
        lines.append(lineno)
    return PtcTable(path, cols, lines)


def _is_word(cell: str) -> bool:
    try:
        float(cell)
        return False
    except ValueError:
        return cell not in ("", "nan", "na", "n/a")
