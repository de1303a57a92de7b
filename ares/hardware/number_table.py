"""Small numeric tables a user already has, for ``ares dark-temperature`` ((T, rate) rows) and
``ares fe55 --events`` (event signals, one per line or with row/col columns).

CSV (comma, semicolon or tab) or whitespace-separated, ``#`` comments, an optional header whose
names are matched (case-insensitive) against each field's aliases; without a header the columns
are the fields in the order given. One sentence naming the file and line for a cell that is not a
number; empty and non-finite cells become NaN (the analysis drops them and says so).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ares.errors import InputError
from ares.hardware.ptc_table import _is_word, _split
from ares.safefile import read_regular

MAX_BYTES = 64 * 1024 * 1024


def read_number_table(path, aliases: dict[str, tuple], required: tuple, what: str) -> tuple[dict, list[int]]:
    """({field: float array}, source line of each row). ``aliases``: field -> header names, in
    the column order a headerless table has."""
    path = Path(path)
    raw = read_regular(path, MAX_BYTES, what)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text table (not UTF-8)") from None
    rows = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if not rows:
        raise InputError(f"{path}: the {what} has no rows")
    delim = next((d for d in (",", ";", "\t") if d in rows[0][1]), None)
    head = [c.strip().lower() for c in _split(rows[0][1], delim, path, rows[0][0])]
    if any(_is_word(c) for c in head):
        index = {}
        for fld, names in aliases.items():
            hit = next((n for n in names if n in head), None)
            if hit is not None:
                index[fld] = head.index(hit)
        rows = rows[1:]
        missing = [f for f in required if f not in index]
        if missing:
            raise InputError(f"{path}: no column for {', '.join(missing)} (header names: "
                             + "; ".join(f"{f}: {', '.join(aliases[f])}" for f in missing) + ")")
    else:
        index = {f: i for i, f in enumerate(aliases) if i < len(head)}
        missing = [f for f in required if f not in index]
        if missing:
            raise InputError(f"{path}:{rows[0][0]}: {len(head)} column(s) and no header; the {what} needs "
                             + ", ".join(required))
    if not rows:
        raise InputError(f"{path}: the {what} has a header but no data rows")
    cols = {f: [] for f in index}
    lines = []
    width = max(index.values()) + 1
    for lineno, ln in rows:
        cells = _split(ln, delim, path, lineno)
        if len(cells) < width:
            raise InputError(f"{path}:{lineno}: {len(cells)} column(s), the {what} needs at least {width}")
        for f, i in index.items():
            t = cells[i].strip()
            if t == "" or t.lower() in ("nan", "na", "n/a", "none", "null"):
                cols[f].append(math.nan)
                continue
            try:
                x = float(t)
            except ValueError:
                raise InputError(f"{path}:{lineno}: column '{f}' is not a number") from None
            cols[f].append(x if math.isfinite(x) else math.nan)
        lines.append(lineno)
    return {f: np.asarray(v, np.float64) for f, v in cols.items()}, lines
