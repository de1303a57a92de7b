"""Lot files (``ares batch --lot LOT.xml``): the items of a lot and the limits their key
figures are judged against. Same safe parsing and one-sentence ``file:line`` errors as the
scan and system files; item paths are relative to the lot file."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ares.protocol.scan import Limit, parse_limit
from ares.protocol.xmlsafe import fail, load


@dataclass(frozen=True)
class LotItem:
    path: Path
    sensor: str = ""
    x: float | None = None
    y: float | None = None


@dataclass(frozen=True)
class Lot:
    name: str
    path: Path
    items: tuple[LotItem, ...]
    limits: tuple[Limit, ...]
    description: str = ""


def load_lot(path: str | Path) -> Lot:
    path = Path(path)
    root = load(path, "lot").getroot()
    base = path.resolve().parent
    items = []
    for el in root.iterfind("item"):
        p = Path(el.get("path"))
        if (el.get("x") is None) != (el.get("y") is None):
            raise fail(path, el.sourceline, f"item '{p}': a wafer position needs both x= and y=")
        items.append(LotItem(p if p.is_absolute() else base / p, el.get("sensor") or "",
                             None if el.get("x") is None else float(el.get("x")),
                             None if el.get("y") is None else float(el.get("y"))))
    limits = [parse_limit(el, path) for el in root.iterfind("limits/limit")]
    desc = root.findtext("description") or ""
    return Lot(root.get("name"), path, tuple(items), tuple(limits), " ".join(desc.split()))
