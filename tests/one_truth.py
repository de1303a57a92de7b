"""One truth on every surface (issue 34): each shipped scan is run as a user runs it
(``test_report_kinds`` runs them and calls ``check_surfaces``), and every figure is read
back from what the user sees -- the terminal, scan_results.json,
key_figures.csv, report.h5, the PDF's text and the window's models -- and compared:
the same value, SE, unit, digits and verdict wherever it appears. A key figure that is
in the tables but missing from the PDF, or a component the terminal prints that the PDF,
the CSV or the window state differently, fails.

(The terminal is a summary: it prints the photon-transfer figures, the decomposition's
components and every scan-level analysis's estimates, not the derived table rows such as
the alternative full-well definitions; those are in the PDF, CSV, HDF5 and JSON.)"""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import h5py
import numpy as np

from ares import labels
from ares.analysis.stats.estimate import Estimate, component_text, exact_why, format_dict
from pdftext import page_texts



def _squash(text: str) -> str:
    return re.sub(r"\s+", " ", text)


def _terminal_blocks(text: str) -> tuple[dict, dict]:
    """(photon-transfer label -> text, component -> text) as printed."""
    ptc, comps, block = {}, {}, None
    ptc_labels = {label for _, label in labels.PTC_FIGURES}
    for line in text.splitlines():
        if line == "photon transfer:":
            block = "ptc"
            continue
        if line.startswith("noise components at stage"):
            block = "comps"
            continue
        if not line.startswith("  "):
            block = None
            continue
        if block == "ptc":
            label = next((lb for lb in sorted(ptc_labels, key=len, reverse=True)
                          if line[2:].startswith(lb + " ")), None)
            if label:
                ptc[label] = line[2 + len(label):].strip()
        elif block == "comps" and not line.startswith("   "):
            m = re.match(r"  (\S+)\s+(.*)$", line)
            if m and m.group(1) in labels.COMPONENTS:
                # the text is everything up to the label, which starts after >= 1 space at col 51
                comps[m.group(1)] = line[17:51].rstrip() if len(line) > 51 and line[51 - 1] == " " else \
                    line[17:].rsplit("  ", 1)[0].strip()
    return ptc, comps


def _key_figures(run: Path) -> list[dict]:
    with open(run / "key_figures.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _h5_key_figures(run: Path) -> list[dict]:
    with h5py.File(run / "report.h5", "r") as f:
        g = f["key_figures"]
        cols = json.loads(g.attrs["columns"])
        data = {c: g[c][()] for c in cols}
    n = len(next(iter(data.values()))) if data else 0
    rows = []
    for i in range(n):
        r = {}
        for c in cols:
            v = data[c][i]
            r[c] = v.decode() if isinstance(v, bytes) else v
        rows.append(r)
    return rows


def _num(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b or abs(a - b) <= 1e-12 * max(abs(a), abs(b))


def _at(tree: dict, dotted: str):
    node = tree
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def check_surfaces(name: str, run: Path, terminal: str) -> None:
    """Every figure of the run in ``run`` the same on every surface (``terminal``: what
    ``ares run`` printed on stdout)."""
    res = json.loads((run / "scan_results.json").read_text())["analyses"]
    kf = _key_figures(run)
    pdf = _squash(" ".join(page_texts(run / "report.pdf")))

    # CSV and HDF5: the same rows
    h5 = _h5_key_figures(run)
    assert [r["name"] for r in kf] == [r["name"] for r in h5]
    for a, b in zip(kf, h5):
        assert _same(_num(a["value"]), _num(b["value"])) and _same(_num(a["se"]), _num(b["se"])), a["name"]
        assert (a["unit"], a["verdict"], a["label"]) == (b["unit"], b["verdict"], b["label"]), a["name"]

    # CSV and JSON: a figure taken from scan_results.json is that figure, to the bit
    for r in kf:
        src = r.get("source", "")
        if src.startswith("scan_results.json: "):
            analysis = src.removeprefix("scan_results.json: ")
            j = _at(res.get(analysis) or {}, r["name"].removeprefix(analysis + ".")) \
                if r["name"].startswith(analysis + ".") else (res.get(analysis) or {}).get(r["name"])
            if isinstance(j, dict) and "value" in j:
                assert _same(_num(r["value"]), _num(j["value"])), (r["name"], r["value"], j)
                assert _same(_num(r["se"]), _num(j.get("se"))), (r["name"], r["se"], j)
                assert r["unit"] == j.get("unit", ""), r["name"]

    # every available key figure is in the PDF with the same digits and unit
    for r in kf:
        why = exact_why(r["note"].split(";")[0]) if _num(r["se"]) == 0 else ""  # (an exact figure's note leads
        e = Estimate(_num(r["value"]), _num(r["se"]), r["unit"],  # with its verdict: note_text)
                     bound={"upper limit": "upper", "lower limit": "lower"}.get(r["verdict"], ""), exact=why)
        if e.available:
            assert _squash(e.text()) in pdf, f"{name}: key figure {r['name']} = {e.text()} not in the PDF"

    # terminal: the photon-transfer block as the JSON and the key figures state it, and
    # the window's Information tab the same
    ptc_t, comps_t = _terminal_blocks(terminal)
    ptc = res.get("ptc") or {}
    by_name = {r["name"]: r for r in kf}
    from ares.gui.runner_adapter import summarize

    gui = summarize(res)["results"]
    # one turnoff (issue 34): turnoff_dn / turnoff_e, not a second "full well, PTC turnoff"
    # with another SE for the same level
    assert not any("ptc_turnoff" in r["name"] for r in kf), name
    for key in ("turnoff_dn", "turnoff_e"):
        if isinstance(ptc.get(key), dict):
            assert key in by_name and by_name[key]["verdict"] == ptc[key]["verdict"], (name, key)
    # the headline K beside EMVA 1288 4.0 Eq. 50 (a scan with emva4): one sentence on the
    # terminal, in the key figures, on the report's page 1 and on the datasheet's notes page
    stmt = (ptc.get("gain_headline") or {}).get("statement")
    if stmt:
        assert "headline K" in terminal and stmt in terminal, name
        assert by_name["gain_dn_per_e"]["note"] == stmt, name
        assert _squash(page_texts(run / "report.pdf")[0]).count(_squash(stmt)) == 1, \
            f"{name}: K statement not on page 1 once (the K key figure's note)"
        sheet = _squash(" ".join(page_texts(run / "emva_datasheet.pdf")))
        assert _squash(stmt) in sheet, f"{name}: K statement not on the datasheet"
    for key, label in labels.PTC_FIGURES:
        if label not in ptc_t:
            continue
        assert ptc_t[label] == format_dict(ptc.get(key), with_reason=True), (name, key)
        if key in by_name and by_name[key]["verdict"] == "ok":
            r = by_name[key]
            assert ptc_t[label] == Estimate(_num(r["value"]), _num(r["se"]), r["unit"]).text(), (name, key)
        from ares.gui.models.session import headline_key

        if headline_key(label) in gui:
            assert gui[headline_key(label)] == ptc_t[label], (name, key)

    # the decomposition: terminal, JSON, components.csv, the PDF's components page and the
    # window's Noise Components table state the same components
    dec = res.get("decomposition")
    if isinstance(dec, dict) and dec.get("components"):
        assert comps_t, f"{name}: the terminal printed no components"
        for c, text in comps_t.items():
            assert text == component_text(c, dec["components"][c]), (name, c, text)
        stage = next(json.loads(p.read_text()) for p in sorted((run / "stages").glob("*.json"))
                     if json.loads(p.read_text())["name"] == dec["stage"])
        part = "components_masked" if "components_masked" in stage["views"]["full"] else "components"
        with open(run / "components.csv", newline="") as fh:
            rows = {r["component"]: r for r in csv.DictReader(fh)
                    if r["stage"] == dec["stage"] and r["view"] == "full" and r["part"] == part}
        from ares.gui.models.components import ComponentsModel

        m = ComponentsModel()
        m.set_stage("x", stage["views"])
        shown = {row.symbol: f"{row.text} {row.shown_unit}".strip() for row in m.rows()}
        for c, d in dec["components"].items():
            text = component_text(c, d)
            assert _same(_num(rows[c]["value"]), _num(d.get("value"))), (name, c)
            if d.get("value") is not None:
                assert _squash(text) in pdf, f"{name}: component {c} = {text} not on the PDF's components page"
                assert shown[c] == text.split(" (")[0] if text.startswith("<") else shown[c] == text, \
                    (name, c, shown[c], text)


def check_defect_classes(name: str, run: Path, terminal: str) -> None:
    """A defect class the run cannot test (issue 34) is "not available" with the same
    reason -- what it needs (frames, an exposure) first -- on every surface, never a count:
    scan_results.json, report.h5, the terminal, the PDF's detection-limits table and the
    window's defect table."""
    res = json.loads((run / "scan_results.json").read_text())["analyses"]
    d = res.get("defects")
    if not isinstance(d, dict) or not d.get("counts"):
        return
    with h5py.File(run / "report.h5") as f:
        h5 = json.loads(f.attrs["scan_results"])["analyses"]["defects"]
    pdf = _squash(" ".join(page_texts(run / "report.pdf")))
    from ares.gui.runner_adapter import summarize

    gui = summarize(res)
    for cls, why in (d.get("unavailable") or {}).items():
        assert why.startswith("needs"), (name, cls, why)
        if cls in d["counts"]:
            assert d["counts"][cls] is None and h5["counts"][cls] is None, (name, cls)
            assert gui["defects"][cls] is None, (name, cls)
            assert gui["defect_criteria"][cls] == "not available: " + why, (name, cls)
        assert h5["unavailable"][cls] == why, (name, cls)
        assert f"{cls + ': n/a':<26} {why}" in terminal, (name, cls, why)
        assert _squash(("not available: " + why)[:100]) in pdf, f"{name}: {cls} not available not in the PDF"


def check_masked_names(run: Path) -> None:
    """The PDF's noise page showed the all-pixel Ps (86.6 DN^2) under "DSNU" while the
    terminal showed the defect-free 0.0785 DN^2: both are now shown under their own
    headings in the PDF, and components.csv tells them apart by part and description."""
    pages = [_squash(t) for t in page_texts(run / "report.pdf")]
    page = next(p for p in pages if "Noise components (ANOVA" in p)
    assert "defects excluded" in page and "all pixels" in page and "defect pixels excluded" in page
    with open(run / "components.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["view"] == "full" and r["component"] == "Ps"]
    parts = {r["part"]: r["description"] for r in rows if r["scene"] == "flat"}
    assert parts["components"].endswith("(all pixels)")
    assert parts["components_masked"].endswith("(defect pixels excluded)")
    views = next(p for p in pages if "Components per view" in p)
    assert "full (masked)" in views and "'(masked)': defect pixels excluded" in views and "Pg in % rms" in views


# ------------------------------------------------------------------ issue 52: one name, one value

# "PRNU 7.85 %": a figure (a number with its unit) under the bare name; plot axes ("DSNU 0 5 10") are not
_QUALIFIED = re.compile(r"\b(DSNU|PRNU)\b(?!1288)(?! \((?:defects excluded|all pixels|total-noise model)\))"
                        r"(?! (?:growth|zone|noise|, ))\s*[:=]?\s*[<>]?\s*[0-9.]+(?:\s*±\s*[0-9.]+)?\s*(?:%|e-|DN)(?!\w)")


def check_names(name: str, run: Path, terminal: str) -> None:
    """Issue 52: every headline figure (``ares.report.headline``) under its one name and with
    one value on the terminal, the window's Information tab, key_figures.csv / report.h5 and
    the PDF; no name of the key figures holds two values in one unit; no bare "DSNU"/"PRNU"
    with a number on any PDF page (each is qualified: defects excluded, all pixels, total-noise
    model); every numeric HDF5 column of the report tables carries a unit."""
    from ares.gui.runner_adapter import summarize
    from ares.gui.models.session import figure_key
    from ares.report.headline import headline

    res = json.loads((run / "scan_results.json").read_text())["analyses"]
    kf = _key_figures(run)
    by_name = {r["name"]: r for r in kf}
    seen: dict[tuple[str, str], str] = {}
    for r in kf:  # two values under one name (and unit) fail
        if r["value"] == "" or r["name"].startswith(("full_well_e.", "defects.")):
            continue
        key = (r["label"], r["unit"])
        assert seen.setdefault(key, r["value"]) == r["value"], f"{name}: '{r['label']}' ({r['unit']}) has two values"
    gui = summarize(res)["results"]
    pages = [_squash(t) for t in page_texts(run / "report.pdf")]
    pdf = " ".join(pages)
    term = {}
    for line in terminal.splitlines():
        for key, fname, _ in headline(res):
            if line.startswith(f"  {fname} "):
                term.setdefault(fname, []).append(line[2 + len(fname):].strip())
    for key, fname, d in headline(res):
        text = format_dict(d, with_reason=True)
        assert text in term.get(fname, []), f"{name}: {fname} = {text} not on the terminal"
        assert gui.get(figure_key(key, fname)) == text, f"{name}: window {figure_key(key, fname)} != {text}"
        labels.figure_name(key)  # the one name
        if key in by_name:
            r = by_name[key]
            assert r["label"].startswith(fname), f"{name}: key figure {key} named '{r['label']}', not '{fname}'"
            if r["value"] != "":
                assert _same(_num(r["value"]), _num((d or {}).get("value"))), f"{name}: {key} differs in the CSV"
    for i, page in enumerate(pages):
        m = _QUALIFIED.search(page)
        assert not m, f"{name}: page {i + 1} names a bare {m.group(1)}: ...{page[max(0, m.start() - 60):m.end() + 20]}"
    with h5py.File(run / "report.h5", "r") as f:
        for group in ("ptc", "components", "levels"):
            if group not in f:
                continue
            for col, ds in f[group].items():
                if ds.dtype.kind == "f" and col not in ("value", "se") and not np.isnan(ds[()]).all():
                    assert ds.attrs.get("unit"), f"{name}: report.h5 /{group}/{col} has no unit"
            for col, ds in f[group].items():
                if col.startswith("light_photons_per_pixel"):
                    assert ds.attrs["unit"].startswith("photons/pixel"), (name, col, ds.attrs["unit"])


def check_window_components(name: str, run: Path, terminal: str, qtbot) -> None:
    """The window's Components tab, fed the decomposed stage as the runner's event reaches it,
    shows the components the terminal prints (defects excluded where the run masked), and says
    which pixels they are."""
    import numpy as np

    from ares.gui.main_window import RESULT_TABS, MainWindow
    from ares.gui.runner_adapter import RunnerJob, summarize
    from ares.gui.events import Done

    res = json.loads((run / "scan_results.json").read_text())["analyses"]
    dec = res.get("decomposition")
    if not isinstance(dec, dict) or not dec.get("components"):
        return
    _, comps_t = _terminal_blocks(terminal)
    stage = next(json.loads(p.read_text()) for p in sorted((run / "stages").glob("*.json"))
                 if json.loads(p.read_text())["name"] == dec["stage"])
    job = RunnerJob.__new__(RunnerJob)
    job._dark_level = {}
    shape = tuple(res.get("defects", {}).get("shape") or (4, 4))
    from types import SimpleNamespace

    ev = job._stage_result(SimpleNamespace(result=stage, index=stage["index"],
                                           arrays={"mean": np.zeros(shape), "variance": np.zeros(shape)}))
    w = MainWindow()
    qtbot.addWidget(w)
    w.resize(1280, 800)
    w.show()
    w.session.handle(ev)
    w.session.flush() if hasattr(w.session, "flush") else None
    w.session.handle(Done(summary=summarize(res)))
    w.result_tabs.setCurrentIndex(RESULT_TABS.index("Components"))
    view = w.components
    table = view.tables["components"]
    shown = {table.item(r, 0).text(): f"{table.item(r, 2).text()} {table.item(r, 3).text()}".strip()
             for r in range(table.rowCount())}
    for c, text in comps_t.items():
        want = text.split(" (")[0] if text.startswith("<") else text
        assert shown.get(c) == want, f"{name}: Components tab {c} = {shown.get(c)}, terminal {text}"
    cap = view.caption.text()
    assert ("defects excluded" in cap) == ("masked_pixels" in dec), f"{name}: Components caption '{cap}'"
    w.result_tabs.setCurrentIndex(RESULT_TABS.index("Information"))
    info = dict(w.info.rows())
    for k, v in summarize(res)["results"].items():
        assert info.get(k) == v, f"{name}: Information tab {k} = {info.get(k)}, not {v}"
    w.close()
