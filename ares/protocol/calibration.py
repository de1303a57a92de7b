"""A reference photodiode's calibration table (``<photodiode calibration="pd.csv">``): its
responsivity in A/W against wavelength, with the standard uncertainty (k = 1) of each value
(EMVA 1288 4.0 Linear, Section 9.3: the spectral setup is calibrated with a calibrated
photodiode in the sensor's place). One reader, two layouts, told apart by the column header:

ARES's own table -- CSV, ``#`` comments and blank lines allowed, then the header::

    wavelength_nm,responsivity_a_per_w,u_responsivity_a_per_w
    400,0.120,0.0024                       (u: standard uncertainty, A/W)

A calibration lab's certificate as delivered (the layout of the Harvard/NIST-traceable
files LSST's eotest ships, ``data/qe/Harvard/OD142.csv``) -- metadata lines (a title,
``Lab Temperature: ...``, ``Work. Stds.:,H630,H633``, ``Test Date:,12/15/10``), then::

    Wavelength [nm],Spectral power responsivity [A/W],Relative expanded uncertainty (k = 2) [%]
    350,0.1498,0.72                        (U: relative, expanded with the k the header states)

(units in brackets or parentheses), whose uncertainty becomes u = R x U / 100 / k (GUM
6.2.1: U = k u); a header that says "standard uncertainty" without a k is k = 1, an
expanded one without a k is refused. The metadata lines are kept (``header``) for the run's
provenance. Trailing empty CSV cells
(a spreadsheet's export) are ignored; the text is UTF-8 or, failing that, an 8-bit
encoding (``decode_text``: the certificate's degree and plus-minus signs).

Checked when the system file is loaded: at least two rows, three finite numbers a row,
wavelengths strictly increasing, responsivities above 0, uncertainties not negative (and a
relative one below 100 %). Any fault is one sentence naming the file and its line.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
from dataclasses import dataclass, replace
from pathlib import Path

from ares.errors import InputError

COLUMNS = ("wavelength_nm", "responsivity_a_per_w", "u_responsivity_a_per_w")
MAX_BYTES = 1 << 20  # a certificate's table is a few kB
ARES, CERTIFICATE = "ares", "certificate"  # the two layouts
_CERT_HEAD = re.compile(r"wavelength\s*[\[(]\s*nm\s*[\])]", re.IGNORECASE)  # units in [] or ()
_K = re.compile(r"\(\s*k\s*=\s*([^)\s]+)\s*\)", re.IGNORECASE)
# control characters no CSV text holds (a UTF-16 file's NULs, a binary file): tab, CR, LF allowed
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
FIELDS = "wavelength, responsivity, uncertainty"


@dataclass(frozen=True)
class CalibrationTable:
    """``u_a_per_w``: standard uncertainty (k = 1) in A/W whatever the file gave; ``layout``
    ARES or CERTIFICATE; ``coverage_k`` the k the file's uncertainty column was divided by;
    ``header`` the certificate's metadata lines as (name, text) pairs in file order."""

    wavelength_nm: tuple[float, ...]
    responsivity_a_per_w: tuple[float, ...]
    u_a_per_w: tuple[float, ...]
    source: str = ""
    layout: str = ARES
    coverage_k: float = 1.0
    header: tuple[tuple[str, str], ...] = ()
    sha256: str = ""  # of the file's bytes (which certificate, exactly)

    @property
    def range_text(self) -> str:
        return f"{self.wavelength_nm[0]:g}-{self.wavelength_nm[-1]:g} nm"

    def provenance(self) -> dict:
        """What a run records of the calibration beside its file name: the layout, how its
        uncertainty became a standard one, the certificate's metadata lines as [name, text]
        pairs (a list, not a mapping: the terminal prints a result's mappings as sections) and
        the file's SHA-256."""
        if self.layout == CERTIFICATE:
            unc = f"relative expanded uncertainty U (k = {self.coverage_k:g}) in %, standard u(R) = R U / (100 k)"
        else:
            unc = "standard uncertainty u(R) in A/W (k = 1)"
        return {"layout": "calibration certificate (Wavelength [nm], responsivity [A/W], relative uncertainty [%])"
                if self.layout == CERTIFICATE else "ARES table (wavelength_nm, responsivity_a_per_w, "
                                                   "u_responsivity_a_per_w)",
                "uncertainty": unc, "header": [list(kv) for kv in self.header], "sha256": self.sha256}


def load_calibration(path: str | Path) -> CalibrationTable:
    from ares.safefile import read_regular

    data = read_regular(path, MAX_BYTES, "photodiode calibration table")
    table = parse_calibration(decode_text(data, str(path)), str(path))
    return replace(table, sha256=hashlib.sha256(data).hexdigest())


def decode_text(data: bytes, where: str) -> str:
    """UTF-8 (a BOM allowed), else a certificate's 8-bit text: Mac Roman when its degree sign
    shows (byte 0xA1 before 'C': eotest's Harvard files, "22.5 ¡C" read as Latin-1),
    otherwise Windows-1252 (Latin-1 plus its printable 0x80-0x9F). Refused, naming the line,
    if undecodable or holding control characters -- not a text file then (UTF-16, binary)."""
    try:
        text, enc = data.decode("utf-8-sig"), "UTF-8"
    except UnicodeDecodeError:
        enc = "Mac Roman" if re.search(rb"\xa1 ?[CF]\b", data) and b"\xb0" not in data else "Windows-1252"
        try:
            text = data.decode("mac_roman" if enc == "Mac Roman" else "cp1252")
        except UnicodeDecodeError as exc:
            line = data.count(b"\n", 0, exc.start) + 1
            raise InputError(f"{where}:{line}: byte {data[exc.start]:#04x} is "
                             "not text in UTF-8 or Windows-1252/Latin-1 (the photodiode calibration table must "
                             "be a CSV text file)") from None
    bad = _CONTROL.search(text)
    if bad:
        line = text.count("\n", 0, bad.start()) + 1
        raise InputError(f"{where}:{line}: character {ord(bad.group()):#04x} is not text (read as {enc}: the "
                         "photodiode calibration table must be a CSV text file in UTF-8 or Latin-1, not UTF-16 "
                         "or binary)")
    return text


def _cells(raw: str) -> list[str]:
    """A line's CSV cells (quotes honoured), stripped, trailing empty ones dropped."""
    cells = [c.strip() for c in next(csv.reader([raw]), [])]
    while cells and not cells[-1]:
        cells.pop()
    return cells


def parse_calibration(text: str, where: str) -> CalibrationTable:
    lines = text.splitlines()
    for n, raw in enumerate(lines, 1):
        if raw.split("#", 1)[0].strip() and tuple(c.lower() for c in _cells(raw.split("#", 1)[0])) == COLUMNS:
            return _ares_table(lines, n, where)
        cells = _cells(raw)
        if cells and _CERT_HEAD.fullmatch(cells[0]):
            return _certificate(lines, n, cells, where)
    first = next(((n, ln.strip()) for n, ln in enumerate(lines, 1) if ln.split("#", 1)[0].strip()), None)
    if first is None:
        raise InputError(f"{where}: no header line '{','.join(COLUMNS)}' (the file is empty)")
    raise InputError(f"{where}:{first[0]}: the header must be '{','.join(COLUMNS)}' (ARES's table) or 'Wavelength "
                     f"[nm],<responsivity> [A/W],<relative uncertainty> (k = 2) [%]' (a calibration certificate), "
                     f"not '{first[1]}'")


def _ares_table(lines: list[str], head: int, where: str) -> CalibrationTable:
    notes = []
    for n, raw in enumerate(lines[:head - 1], 1):
        if raw.split("#", 1)[0].strip():
            raise InputError(f"{where}:{n}: the header must be '{','.join(COLUMNS)}', not '{raw.strip()}'")
        if raw.strip().lstrip("#").strip():
            notes.append(raw.strip().lstrip("#").strip())
    rows = []
    for n, raw in enumerate(lines[head:], head + 1):
        line = raw.split("#", 1)[0].strip()
        if line:
            rows.append(_row(_cells(line), line, n, where, rows))  # u in A/W already
    table = _table(rows, head, where)
    return CalibrationTable(*table, where, ARES, 1.0, (("comment", " ".join(notes)),) if notes else ())


def _certificate(lines: list[str], head: int, cells: list[str], where: str) -> CalibrationTable:
    if len(cells) != 3 or not re.search(r"[\[(]a/w[\])]", cells[1].lower().replace(" ", "")):
        raise InputError(f"{where}:{head}: a calibration certificate's header must name 3 columns, wavelength [nm], "
                         f"responsivity [A/W] and its relative uncertainty [%], not '{','.join(cells)}'")
    unc = cells[2].lower()
    if not unc.replace(" ", "").endswith(("[%]", "(%)")):
        raise InputError(f"{where}:{head}: the uncertainty column must be relative, in % ('... [%]'), not '{cells[2]}'")
    m = _K.search(cells[2])
    if m:
        try:
            k = float(m.group(1))
        except ValueError:
            k = math.nan
        if not (math.isfinite(k) and k >= 1):
            raise InputError(f"{where}:{head}: coverage factor 'k = {m.group(1)}' in '{cells[2]}' is not a number "
                             "of 1 or more")
    elif "expanded" in unc:
        raise InputError(f"{where}:{head}: the expanded uncertainty '{cells[2]}' states no coverage factor "
                         "'(k = 2)': its standard uncertainty cannot be known")
    elif "standard" in unc:
        k = 1.0
    else:
        raise InputError(f"{where}:{head}: '{cells[2]}' says neither 'standard' nor 'expanded (k = ...)' "
                         "uncertainty: its coverage factor cannot be known")
    meta = []
    for n, raw in enumerate(lines[:head - 1], 1):
        c = _cells(raw)
        if not c:
            continue
        if ":" in c[0]:
            name, first = (s.strip() for s in c[0].split(":", 1))
            meta.append((name, ", ".join(x for x in [first, *c[1:]] if x)))
        else:
            meta.append(("title", ", ".join(x for x in c if x)))
    rows = []
    for n, raw in enumerate(lines[head:], head + 1):
        c = _cells(raw)
        if not c:
            continue
        nm, r, u_pct = _row(c, raw.strip(), n, where, rows)
        if u_pct >= 100:
            raise InputError(f"{where}:{n}: relative uncertainty {u_pct:g} % at {nm:g} nm is not below 100 %")
        rows.append((nm, r, r * u_pct / 100.0 / k))
    return CalibrationTable(*_table(rows, head, where), where, CERTIFICATE, k, tuple(meta))


def _row(cells: list[str], line: str, n: int, where: str, rows: list) -> tuple[float, float, float]:
    """One data row checked against the rows before it: (wavelength nm, responsivity A/W,
    uncertainty: A/W or % as the layout has it)."""
    if len(cells) != 3 or not all(cells):
        got = f"{len(cells)}" if len(cells) > 3 else f"{sum(1 for c in cells if c)} (a field is missing)"
        raise InputError(f"{where}:{n}: expected 3 fields ({FIELDS}), got {got}: '{line}'")
    try:
        nm, r, u = (float(c) for c in cells)
    except ValueError:
        raise InputError(f"{where}:{n}: '{line}' holds a field that is not a number") from None
    if not all(math.isfinite(v) for v in (nm, r, u)):
        raise InputError(f"{where}:{n}: every field must be a finite number, got '{line}'")
    if nm <= 0:
        raise InputError(f"{where}:{n}: wavelength {nm:g} nm must be above 0")
    if rows and nm <= rows[-1][0]:
        raise InputError(f"{where}:{n}: wavelength {nm:g} nm does not follow {rows[-1][0]:g} nm "
                         "(wavelengths must increase line by line)")
    if r <= 0:
        raise InputError(f"{where}:{n}: responsivity {r:g} A/W at {nm:g} nm must be above 0")
    if u < 0:
        raise InputError(f"{where}:{n}: uncertainty {u:g} at {nm:g} nm must not be negative")
    return nm, r, u


def _table(rows: list, head: int, where: str) -> tuple[tuple, tuple, tuple]:
    if len(rows) < 2:
        raise InputError(f"{where}:{head}: a calibration table needs at least 2 wavelengths, found {len(rows)}")
    return tuple(r[0] for r in rows), tuple(r[1] for r in rows), tuple(r[2] for r in rows)
