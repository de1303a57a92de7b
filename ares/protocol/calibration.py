"""A reference photodiode's calibration table (``<photodiode calibration="pd.csv">``): its
responsivity in A/W against wavelength, with the standard uncertainty of each value, as
the calibration certificate gives it (EMVA 1288 4.0 Linear, Section 9.3: the spectral
setup is calibrated with a calibrated photodiode in the sensor's place).

CSV, comma-separated, ``#`` comments and blank lines allowed, a header naming the columns::

    wavelength_nm,responsivity_a_per_w,u_responsivity_a_per_w
    400,0.120,0.0024
    ...

Checked when the system file is loaded: at least two rows, every field a finite number,
wavelengths strictly increasing, responsivities above 0, uncertainties not negative. Any
fault is one sentence naming the file and its line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ares.errors import InputError

COLUMNS = ("wavelength_nm", "responsivity_a_per_w", "u_responsivity_a_per_w")
MAX_BYTES = 1 << 20  # a certificate's table is a few kB


@dataclass(frozen=True)
class CalibrationTable:
    wavelength_nm: tuple[float, ...]
    responsivity_a_per_w: tuple[float, ...]
    u_a_per_w: tuple[float, ...]
    source: str = ""

    @property
    def range_text(self) -> str:
        return f"{self.wavelength_nm[0]:g}-{self.wavelength_nm[-1]:g} nm"


def load_calibration(path: str | Path) -> CalibrationTable:
    from ares.safefile import read_regular

    data = read_regular(path, MAX_BYTES, "photodiode calibration table")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file (the photodiode calibration table is CSV)") from None
    return parse_calibration(text, str(path))


def parse_calibration(text: str, where: str) -> CalibrationTable:
    header, rows = None, []
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        cells = [c.strip() for c in line.split(",")]
        if header is None:
            if tuple(c.lower() for c in cells) != COLUMNS:
                raise InputError(f"{where}:{n}: the header must be '{','.join(COLUMNS)}', not '{line}'")
            header = n
            continue
        if len(cells) != 3:
            raise InputError(f"{where}:{n}: expected 3 fields (wavelength, responsivity, uncertainty), got {len(cells)}")
        try:
            nm, r, u = (float(c) for c in cells)
        except ValueError:
            raise InputError(f"{where}:{n}: '{line}' holds a field that is not a number") from None
        if not all(math.isfinite(v) for v in (nm, r, u)):
            raise InputError(f"{where}:{n}: every field must be a finite number, got '{line}'")
        if nm <= 0:
            raise InputError(f"{where}:{n}: wavelength {nm:g} nm must be above 0")
        if rows and nm <= rows[-1][1]:
            raise InputError(f"{where}:{n}: wavelength {nm:g} nm does not follow {rows[-1][1]:g} nm "
                             "(wavelengths must increase line by line)")
        if r <= 0:
            raise InputError(f"{where}:{n}: responsivity {r:g} A/W at {nm:g} nm must be above 0")
        if u < 0:
            raise InputError(f"{where}:{n}: uncertainty {u:g} A/W at {nm:g} nm must not be negative")
        rows.append((n, nm, r, u))
    if header is None:
        raise InputError(f"{where}: no header line '{','.join(COLUMNS)}' (the file is empty)")
    if len(rows) < 2:
        raise InputError(f"{where}:{header}: a calibration table needs at least 2 wavelengths, found {len(rows)}")
    return CalibrationTable(tuple(r[1] for r in rows), tuple(r[2] for r in rows), tuple(r[3] for r in rows), where)
