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
class HardBin:
    """``<bins><hard number name pass>``: a hard bin (the handler's bin) and whether it is good."""

    number: int
    name: str
    passed: bool = False


@dataclass(frozen=True)
class SoftBin:
    """``<bins><soft number hard name for>``: a soft bin, its hard bin and the role it takes
    (``pass``, ``error``, ``limit``/``pat``: limits/screens without their own ``soft_bin=``;
    "" only the limits and screens whose ``soft_bin=`` names it)."""

    number: int
    hard: int
    name: str
    role: str = ""


@dataclass(frozen=True)
class Lot:
    name: str
    path: Path
    items: tuple[LotItem, ...]
    limits: tuple[Limit, ...]
    description: str = ""
    limit_bins: tuple[int | None, ...] = ()  # the soft bin of each limit (None: the default)
    screens: tuple[Pat, ...] = ()
    hard_bins: tuple[HardBin, ...] = ()  # declared in <bins>; () -- the default bins (ares.batch.screens)
    soft_bins: tuple[SoftBin, ...] = ()


def _bins(root, path: Path, limit_els, pat_els) -> tuple[tuple[HardBin, ...], tuple[SoftBin, ...]]:
    """The declared bins, checked: every number once, every soft bin in a declared hard bin,
    one soft bin for="pass" in a pass hard bin and one for="error" in a fail one, every
    limit's and screen's soft bin declared and failing; each fault one sentence file:line."""
    el = root.find("bins")
    if el is None:  # the default bins: soft 1 and 99 are the pass and the could-not-be-analysed bin
        for e in (*limit_els, *pat_els):
            if e.get("soft_bin") in ("1", "99"):
                raise fail(path, e.sourceline, f"{e.tag} on '{e.get('quantity')}': soft bin {e.get('soft_bin')} is "
                                               f"the default {'pass' if e.get('soft_bin') == '1' else 'error'} bin; "
                                               f"choose another, or declare the bins in <bins>")
        return (), ()
    hard: dict[int, HardBin] = {}
    for h in el.iterfind("hard"):
        n = int(h.get("number"))
        if n in hard:
            raise fail(path, h.sourceline, f"hard bin {n} is declared twice")
        hard[n] = HardBin(n, h.get("name"), h.get("pass", "false") in ("true", "1"))
    soft: dict[int, SoftBin] = {}
    roles: dict[str, SoftBin] = {}
    for s in el.iterfind("soft"):
        b = SoftBin(int(s.get("number")), int(s.get("hard")), s.get("name"), s.get("for") or "")
        if b.number in soft:
            raise fail(path, s.sourceline, f"soft bin {b.number} is declared twice")
        if b.hard not in hard:
            raise fail(path, s.sourceline, f"soft bin {b.number} is in hard bin {b.hard}, which <bins> does not "
                                           f"declare (declared: {', '.join(map(str, sorted(hard)))})")
        if b.role in roles:
            raise fail(path, s.sourceline, f"soft bins {roles[b.role].number} and {b.number} are both "
                                           f'for="{b.role}"; one soft bin takes each role')
        good = hard[b.hard].passed
        if b.role == "pass" and not good:
            raise fail(path, s.sourceline, f'soft bin {b.number} is for="pass" but its hard bin {b.hard} is not a '
                                           f'pass bin (pass="true")')
        if b.role and b.role != "pass" and good:
            raise fail(path, s.sourceline, f'soft bin {b.number} is for="{b.role}" but its hard bin {b.hard} is a '
                                           f"pass bin: failed items would count as good")
        soft[b.number] = b
        if b.role:
            roles[b.role] = b
    for role in ("pass", "error"):
        if role not in roles:
            raise fail(path, el.sourceline, f'<bins> declares no soft bin for="{role}" (the items that '
                                            f'{"pass every limit and screen" if role == "pass" else "could not be analysed"})')
    for kind, els in (("limit", limit_els), ("pat", pat_els)):
        for e in els:
            what = f"{kind} on '{e.get('quantity')}'"
            if e.get("soft_bin") is None:
                if kind not in roles:
                    raise fail(path, e.sourceline, f'{what} has no soft_bin= and <bins> declares no soft bin '
                                                   f'for="{kind}" to take its failures')
                continue
            n = int(e.get("soft_bin"))
            if n not in soft:
                raise fail(path, e.sourceline, f"{what}: soft bin {n} is not declared in <bins> (declared: "
                                               f"{', '.join(map(str, sorted(soft)))})")
            if hard[soft[n].hard].passed or soft[n].role in ("pass", "error"):
                raise fail(path, e.sourceline, f"{what}: soft bin {n} takes "
                                               f"{'good items' if hard[soft[n].hard].passed else 'unanalysable items'}"
                                               f", not the failures of a {kind}")
    return tuple(hard.values()), tuple(soft.values())


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
    pat_els = list(root.iterfind("limits/pat"))
    for el in pat_els:
        k = float(el.get("k", PAT_K))
        if k <= 0:
            raise fail(path, el.sourceline, f"pat on '{el.get('quantity')}': k must be above 0, not {k:g}")
        screens.append(Pat(el.get("quantity"), k, None if el.get("soft_bin") is None else int(el.get("soft_bin"))))
    hard, soft = _bins(root, path, els, pat_els)
    desc = root.findtext("description") or ""
    return Lot(root.get("name"), path, tuple(items), tuple(limits), " ".join(desc.split()), bins, tuple(screens),
               hard, soft)
