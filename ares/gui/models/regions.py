"""Regions of Analysis (RoA): the table's rows, and the RoA file (XML or CSV).

A region is a rectangle in pixel coordinates (x = column, y = row of its top-left
corner) with two flags: ``on`` (analysed, outlined on the images) and ``draw`` (its
outline on the live image has handles to move and resize it with the mouse). The RoA
file holds only the rectangles and flags -- no other GUI state.

XML form::

    <roa version="1">
      <region on="1" draw="0" x="4" y="6" width="128" height="108"/>
    </roa>

CSV form: a header ``on,draw,x,y,width,height`` and one row per region.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ares.errors import InputError

from ares.gui.models.observable import Observable

FIELDS = ("on", "draw", "x", "y", "width", "height")
DEFAULT_ROWS = 16


@dataclass(frozen=True)
class Region:
    on: bool = False
    draw: bool = False
    x: int = 0
    y: int = 0
    width: int = 0
    height: int = 0

    @property
    def empty(self) -> bool:
        return self.width <= 0 or self.height <= 0

    def clipped(self, shape: tuple[int, int]) -> tuple[slice, slice] | None:
        """(row slice, column slice) of this region inside an image of ``shape``,
        or None when nothing of it lies inside."""
        rows, cols = shape
        r0, r1 = max(self.y, 0), min(self.y + self.height, rows)
        c0, c1 = max(self.x, 0), min(self.x + self.width, cols)
        if self.empty or r1 <= r0 or c1 <= c0:
            return None
        return slice(r0, r1), slice(c0, c1)

    def crop(self, image: np.ndarray) -> np.ndarray | None:
        sl = self.clipped(image.shape[-2:])
        return None if sl is None else image[..., sl[0], sl[1]]


def full_frame(shape: tuple[int, int]) -> Region:
    return Region(on=True, draw=False, x=0, y=0, width=int(shape[1]), height=int(shape[0]))


class RegionSet(Observable):
    """The RoA table's content: a fixed number of rows, as in ARES (16)."""

    def __init__(self, regions: list[Region] | None = None, rows: int = DEFAULT_ROWS) -> None:
        super().__init__()
        regions = list(regions or [])
        self.regions: list[Region] = regions + [Region()] * max(0, rows - len(regions))

    def __len__(self) -> int:
        return len(self.regions)

    def __getitem__(self, i: int) -> Region:
        return self.regions[i]

    def set(self, i: int, region: Region) -> None:
        if region.width < 0 or region.height < 0:
            raise InputError(f"region {i + 1}: width and height must not be negative")
        if region != self.regions[i]:
            self.regions[i] = region
            self._changed()

    def update(self, i: int, **fields) -> None:
        self.set(i, replace(self.regions[i], **fields))

    def add(self, region: Region) -> int:
        """Put ``region`` in the first unused row (off and empty), or append a row."""
        for i, r in enumerate(self.regions):
            if r == Region():
                self.set(i, region)
                return i
        self.regions.append(region)
        self._changed()
        return len(self.regions) - 1

    def replace_all(self, regions: list[Region]) -> None:
        rows = max(DEFAULT_ROWS, len(regions))
        self.regions = list(regions) + [Region()] * (rows - len(regions))
        self._changed()

    def active(self) -> list[tuple[int, Region]]:
        """(row index, region) of every region that is on and not empty."""
        return [(i, r) for i, r in enumerate(self.regions) if r.on and not r.empty]

    def drawn(self) -> list[tuple[int, Region]]:
        """Regions with Draw ticked: editable with the mouse on the live image."""
        return [(i, r) for i, r in enumerate(self.regions) if r.draw and not r.empty]

    def visible(self) -> list[tuple[int, Region]]:
        """Regions outlined on the images: every active one, and any being drawn."""
        return [(i, r) for i, r in enumerate(self.regions) if (r.on or r.draw) and not r.empty]

    # ---- RoA file -------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        save_roa(path, [r for r in self.regions if r != Region()])

    def load(self, path: str | Path) -> None:
        self.replace_all(load_roa(path))


def save_roa(path: str | Path, regions: list[Region]) -> None:
    path = Path(path)
    if path.suffix.lower() == ".csv":
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(FIELDS)
        for r in regions:
            w.writerow([int(r.on), int(r.draw), r.x, r.y, r.width, r.height])
        text = buf.getvalue()
    else:
        lines = ['<?xml version="1.0" encoding="UTF-8"?>', '<roa version="1">']
        for r in regions:
            lines.append(
                f'  <region on="{int(r.on)}" draw="{int(r.draw)}" x="{r.x}" y="{r.y}"'
                f' width="{r.width}" height="{r.height}"/>'
            )
        lines.append("</roa>")
        text = "\n".join(lines) + "\n"
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot write the RoA file ({exc.strerror or exc}).") from None


def _int(value: str, where: str, name: str, flag: bool = False) -> int:
    try:
        v = int(str(value).strip())
    except ValueError:
        raise InputError(f"{where}: {name}={value!r} is not an integer.") from None
    if flag and v not in (0, 1):
        raise InputError(f"{where}: {name} must be 0 or 1, not {v}.")
    if not flag and name in ("width", "height") and v < 0:
        raise InputError(f"{where}: {name} must not be negative.")
    return v


def _region(values: dict, where: str) -> Region:
    missing = [f for f in FIELDS if values.get(f) in (None, "")]
    if missing:
        raise InputError(f"{where}: region lacks {', '.join(missing)}.")
    return Region(
        on=bool(_int(values["on"], where, "on", flag=True)),
        draw=bool(_int(values["draw"], where, "draw", flag=True)),
        **{f: _int(values[f], where, f) for f in ("x", "y", "width", "height")},
    )


def load_roa(path: str | Path) -> list[Region]:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot read the RoA file ({exc.strerror or exc}).") from None
    if path.suffix.lower() == ".csv":
        rows = list(csv.DictReader(io.StringIO(text)))
        return [_region(row, f"{path}, line {i + 2}") for i, row in enumerate(rows)]
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    try:
        root = etree.fromstring(text.encode("utf-8"), parser)
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno is not None else "?"
        raise InputError(f"{path}, line {line}: the RoA file is not well-formed XML.") from None
    if root.tag != "roa":
        raise InputError(f"{path}, line {root.sourceline}: expected a <roa> root element, found <{root.tag}>.")
    return [
        _region(dict(el.attrib), f"{path}, line {el.sourceline}")
        for el in root
        if isinstance(el.tag, str) and el.tag == "region"
    ]
