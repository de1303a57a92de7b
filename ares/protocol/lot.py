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
    wafer: str = ""


PAT_K = 6.0  # the automotive part-average-testing rule (AEC-Q001): robust mean +- 6 robust sigma


@dataclass(frozen=True)
class Pat:
    """``<pat quantity k soft_bin>``: a dynamic limit the lot sets itself (``ares.batch.screens``)."""

    quantity: str
    k: float = PAT_K
    soft_bin: int | None = None


@dataclass(frozen=True)
class Lot:
    name: str
    path: Path
    items: tuple[LotItem, ...]
    limits: tuple[Limit, ...]
    description: str = ""
    limit_bins: tuple[int | None, ...] = ()  # the soft bin of each limit (None: the default)
    screens: tuple[Pat, ...] = ()


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
                             None if el.get("y") is None else float(el.get("y")), el.get("wafer") or ""))
    els = list(root.iterfind("limits/limit"))
    limits = [parse_limit(el, path) for el in els]
    bins = tuple(None if el.get("soft_bin") is None else int(el.get("soft_bin")) for el in els)
    screens = []
    for el in root.iterfind("limits/pat"):
        k = float(el.get("k", PAT_K))
        if k <= 0:
            raise fail(path, el.sourceline, f"pat on '{el.get('quantity')}': k must be above 0, not {k:g}")
        screens.append(Pat(el.get("quantity"), k, None if el.get("soft_bin") is None else int(el.get("soft_bin"))))
    desc = root.findtext("description") or ""
    return Lot(root.get("name"), path, tuple(items), tuple(limits), " ".join(desc.split()), bins, tuple(screens))
