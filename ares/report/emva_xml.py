"""The EMVA 1288 certification XML: write, read and compare.

The file is the tree of the reference implementation's convention (``ares.results.emva_names``)::

    <results release="3.1" generator="ARES">
      <SECTION>
        <NAME>
          <section>SECTION</section> <short>...</short> <symbol>...</symbol> <unit>...</unit>
          <value>0.2800626484911438</value>          (a scalar; "None" when not available)
          <data><bins>-2.68 -2.66 ...</bins> ...</data>   (an array result instead of value)
          <se>...</se> <bound>lower</bound> <note>...</note>   (ARES's additions)
        </NAME>

A reader of the reference convention reads ``value`` and ``data`` and skips the other
children, so ARES's SE, bound and note travel in the same file. Numbers are written with
``repr`` (17 significant digits: the float itself, not a rounding of it).

``compare`` checks two such files name by name to ``digits`` significant digits (the
reference's certification criterion is 7): PASS, FAIL or MISSING (in one file only), with
both values. It is ARES's own code, running on current NumPy (the reference package's compare
calls ``np.int``, removed in NumPy 1.24). docs/emva_xml.md describes the format.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ares.errors import InputError

MAX_XML_BYTES = 64 << 20
PASS, FAIL, MISSING = "PASS", "FAIL", "MISSING"


def _num(v) -> str:
    return "None" if v is None else repr(float(v))


def to_xml_bytes(tree: dict, release: str) -> bytes:
    from lxml import etree

    root = etree.Element("results", release=release, generator="ARES")
    for section, names in tree.items():
        sec = etree.SubElement(root, section)
        for name, e in names.items():
            el = etree.SubElement(sec, name)
            etree.SubElement(el, "section").text = section
            for k in ("short", "symbol", "unit"):
                if e.get(k):
                    etree.SubElement(el, k).text = e[k]
            if "data" in e:
                if e["data"] is None:
                    etree.SubElement(el, "value").text = "None"
                else:
                    d = etree.SubElement(el, "data")
                    for k, a in e["data"].items():
                        etree.SubElement(d, k).text = " ".join(repr(float(x)) for x in np.asarray(a, float).ravel())
            else:
                etree.SubElement(el, "value").text = _num(e.get("value"))
                if e.get("se") is not None:
                    etree.SubElement(el, "se").text = _num(e["se"])
                if e.get("bound"):
                    etree.SubElement(el, "bound").text = e["bound"]
            if e.get("note"):
                etree.SubElement(el, "note").text = e["note"]
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="utf-8")


def write_xml(tree: dict, release: str, path: Path) -> None:
    from ares.rundir.files import write_atomic

    write_atomic(Path(path), to_xml_bytes(tree, release))


def _float(text: str | None, where: str):
    t = (text or "").strip()
    if t.lower() in ("none", ""):
        return None
    try:
        return float(t.replace(",", "."))  # (the reference's reader accepts a decimal comma too)
    except ValueError:
        raise InputError(f"{where}: '{t[:40]}' is not a number") from None


def read_xml(path: str | Path) -> dict:
    """``{section: {name: {"value": float | None} | {"data": {k: ndarray}}, ...}}`` with the
    names lower-cased (the reference's reader does so too: some writers capitalise them), and
    the root's ``release`` under ``"_release"``."""
    from lxml import etree

    from ares.safefile import read_regular

    path = Path(path)
    raw = read_regular(path, MAX_XML_BYTES, "EMVA 1288 results XML")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    try:
        root = etree.fromstring(raw, parser)
    except etree.XMLSyntaxError as exc:
        raise InputError(f"{path}: not a well-formed XML file ({exc})") from None
    if root.tag != "results":
        raise InputError(f"{path}: the root element is <{root.tag}>, an EMVA 1288 results file has <results>")
    out: dict = {"_release": root.get("release", "")}
    for sec in root:
        if not isinstance(sec.tag, str):
            continue
        names = out.setdefault(sec.tag.lower(), {})
        for el in sec:
            if not isinstance(el.tag, str):
                continue
            where = f"{path}:{el.sourceline}"
            e: dict = {}
            for child in el:
                if not isinstance(child.tag, str):
                    continue
                tag = child.tag.lower()
                if tag == "data":
                    e["data"] = {a.tag.lower(): np.array([_float(t, where) for t in (a.text or "").split()], float)
                                 for a in child if isinstance(a.tag, str)}
                elif tag in ("value", "se"):
                    e[tag] = _float(child.text, where)
                else:
                    e[tag] = (child.text or "").strip()
            names[el.tag.lower()] = e
    return out


def round_significant(v: float, digits: int) -> float:
    """``v`` rounded to ``digits`` significant digits (0, inf and nan as they are)."""
    if v == 0 or not math.isfinite(v):
        return v
    return round(v, digits - 1 - int(math.floor(math.log10(abs(v)))))


def _na(v: float | None) -> bool:
    return v is None or math.isnan(v)


def _same(a: float | None, b: float | None, digits: int) -> bool:
    if _na(a) or _na(b):  # "not available": None (ARES, with its reason) or nan (the reference)
        return _na(a) and _na(b)
    return round_significant(a, digits) == round_significant(b, digits)


@dataclass(frozen=True)
class Row:
    section: str
    name: str
    status: str
    a: str
    b: str
    why: str = ""
    within_limit: bool = False  # a FAIL where one file gives only a limit and the other's value lies within it


def _show(e: dict | None) -> str:
    if e is None:
        return "-"
    if "data" in e:
        return "array(" + ", ".join(f"{k}[{len(v)}]" for k, v in e["data"].items()) + ")"
    v = e.get("value")
    return "None" if v is None else repr(v)


def _compare_arrays(da: dict, db: dict, digits: int) -> str:
    """"" when every array agrees, else why not."""
    if set(da) != set(db):
        return f"arrays differ: {sorted(da)} vs {sorted(db)}"
    for k in sorted(da):
        a, b = da[k], db[k]
        if a.shape != b.shape:
            return f"{k}: {a.size} vs {b.size} elements"
        for i, (x, y) in enumerate(zip(a.tolist(), b.tolist())):
            if not _same(x, y, digits):
                return f"{k}[{i}]: {x!r} vs {y!r}"
    return ""


def compare(a: dict, b: dict, digits: int = 7) -> list[Row]:
    """Every name of either file (sections and names compared lower-case), in order."""
    rows = []
    sections = sorted((set(a) | set(b)) - {"_release"})
    for s in sections:
        na, nb = a.get(s, {}), b.get(s, {})
        for n in sorted(set(na) | set(nb)):
            ea, eb = na.get(n), nb.get(n)
            if ea is None or eb is None:
                rows.append(Row(s, n, MISSING, _show(ea), _show(eb), "only in " + ("B" if ea is None else "A")))
                continue
            if ("data" in ea) != ("data" in eb):
                rows.append(Row(s, n, FAIL, _show(ea), _show(eb), "an array in one file, a value in the other"))
                continue
            why = (_compare_arrays(ea["data"], eb["data"], digits) if "data" in ea else
                   "" if _same(ea.get("value"), eb.get("value"), digits) else f"differ at {digits} digits")
            within = False
            if why and "data" not in ea:
                within, why = _limit_why(ea, eb, why)
            rows.append(Row(s, n, FAIL if why else PASS, _show(ea), _show(eb), why, within))
    return rows


def _limit_why(ea: dict, eb: dict, why: str) -> tuple[bool, str]:
    """(whether the limit holds the other value, the why) for two values that differ where one
    file gives only a limit (ARES's ``bound``: the figure is not resolved, e.g. a linearity
    extreme whose SE exceeds it) and the other a point value (the reference writes every figure
    as its point value): still a FAIL -- the numbers differ --, with whether the limit holds it."""
    bounds = [(e.get("bound") or "").lower() for e in (ea, eb)]
    if (bounds[0] in ("upper", "lower")) == (bounds[1] in ("upper", "lower")):
        return False, why
    i = 0 if bounds[0] in ("upper", "lower") else 1
    lim, other = (ea, eb)[i].get("value"), (eb, ea)[i].get("value")
    if _na(lim) or _na(other):
        return False, why
    within = other <= lim if bounds[i] == "upper" else other >= lim
    return within, (f"{'AB'[i]} is only {'an upper' if bounds[i] == 'upper' else 'a lower'} limit "
                    f"({'<' if bounds[i] == 'upper' else '>'} {lim:.4g}); {'AB'[1 - i]}'s value {other:.4g} is "
                    + ("within it" if within else "outside it"))


def format_rows(rows: list[Row], name_a: str, name_b: str) -> str:
    w = max([24] + [len(f"{r.section}/{r.name}") + 1 for r in rows])
    lines = [f"A: {name_a}", f"B: {name_b}",
             f"{'name':<{w}}{'status':<9}{'A':>24}  {'B':>24}  why"]
    for r in rows:
        lines.append(f"{r.section + '/' + r.name:<{w}}{r.status:<9}{r.a:>24}  {r.b:>24}  {r.why}")
    counts = {s: sum(r.status == s for r in rows) for s in (PASS, FAIL, MISSING)}
    lines.append(f"{len(rows)} names: {counts[PASS]} PASS, {counts[FAIL]} FAIL, {counts[MISSING]} MISSING")
    return "\n".join(lines)
