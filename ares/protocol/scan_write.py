"""A scan written back as XML (the run directory's copy holds the regions drawn in the window): the inverse of ``ares.protocol.scan.load_scan``."""

from __future__ import annotations

from pathlib import Path
from lxml import etree
from ares.protocol.system import _set
from ares.protocol.scan import Scan


def _set_el(parent, tag, key: str, value=None):
    el = etree.SubElement(parent, tag)
    if key.startswith("reg:"):
        el.set("field", key[4:])
    else:
        el.set("quantity", key)
    if value is not None:
        el.set("value", repr(float(value)))
    return el


def scan_to_tree(sc: Scan) -> etree._ElementTree:
    root = _set(etree.Element("scan"), name=sc.name, version=sc.version)
    if sc.description:
        etree.SubElement(root, "description").text = sc.description
    _set(etree.SubElement(root, "system"), href=sc.system_href)
    if sc.settings:
        se = etree.SubElement(root, "settings")
        for s in sc.settings:
            _set_el(se, "set", s.key, s.value)
    fr = _set(etree.SubElement(root, "frames"), on_loss=None if sc.on_loss == "fail" else sc.on_loss,
              max_regrabs=None if sc.max_regrabs == 2 else sc.max_regrabs)
    fr.text = str(sc.frames)

    st = etree.SubElement(root, "stages")
    for s in sc.stages:
        el = _set(etree.SubElement(st, "sweep" if s.sweep else "stage"), name=s.name, scene=s.scene, frames=s.frames,
                  dark=s.dark, dark_frames=s.dark_frames)
        for x in s.settings:
            _set_el(el, "set", x.key, x.value)
        for a in s.axes:
            ax = _set_el(el, "axis", a.key)
            _set(ax, order=None if a.order == "given" else a.order, seed=None if a.order == "given" else a.seed)
            if a.kind == "values":
                etree.SubElement(ax, "values").text = " ".join(repr(float(v)) for v in a.values)
            else:
                _set(etree.SubElement(ax, a.kind), start=float(a.start), stop=float(a.stop), points=a.points)
    if sc.regions:
        rg = etree.SubElement(root, "regions")
        for r in sc.regions:
            _set(etree.SubElement(rg, "region"), name=r.name, x=r.x, y=r.y, width=r.width, height=r.height)
    if sc.analyses:
        an = etree.SubElement(root, "analyses")
        for a in sc.analyses:
            _set(etree.SubElement(an, "analysis"), name=a,
                 **{k: float(v) for a2, k, v in sc.analysis_options if a2 == a})
    if sc.defects or sc.defect_mask:
        de = etree.SubElement(root, "defects")
        _set(de, mask=sc.defect_mask)
        for k, v in sc.defects:
            _set(etree.SubElement(de, "threshold"), name=k, value=float(v))
    if sc.limits:
        li = etree.SubElement(root, "limits")
        for lim in sc.limits:
            _set(etree.SubElement(li, "limit"), quantity=lim.quantity, min=lim.min, max=lim.max)
    if sc.precision is not None:
        p = sc.precision
        pe = _set(etree.SubElement(root, "precision"), budget=p.budget, pilot=p.pilot, confidence=float(p.confidence),
                  se_cv=float(p.se_cv))
        for t in p.targets:
            _set(etree.SubElement(pe, "target"), quantity=t.quantity, rel=t.rel, abs=t.abs)
    if sc.suspend is not None:
        su = _set(etree.SubElement(root, "suspend"), poll_s=sc.suspend.poll_s, hold_s=sc.suspend.hold_s,
                  timeout_s=sc.suspend.timeout_s, max_recoveries=sc.suspend.max_recoveries)
        for q, tol in sc.suspend.conditions:
            _set(etree.SubElement(su, "condition"), quantity=q, tolerance=tol if q != "device" else None)
    o = sc.output
    _set(etree.SubElement(root, "output"), raw_frames=o.raw_frames, hdf5=o.hdf5, csv=o.csv, pdf=o.pdf)
    return etree.ElementTree(root)


def save_scan(sc: Scan, path: str | Path) -> None:
    tree = scan_to_tree(sc)
    etree.indent(tree, space="  ")
    Path(path).write_bytes(etree.tostring(tree, xml_declaration=True, encoding="UTF-8", pretty_print=True))
