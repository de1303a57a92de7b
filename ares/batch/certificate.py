"""A certificate of performance per sensor (``ares lots certificate LOT [ITEM]``): one A4
page a sensor, from the results database alone -- the sensor's identity (serial, lot,
wafer and die position, item), its bin and verdict, every key figure with its SE, unit,
the static limit and the dynamic (part-average-testing) limit on it and the outcome, and
the traceability of the measurement (ARES version of the item and of the lot, the item's
content hash, the SHA-256 of its run directory's manifest when the directory is at hand,
the measurement date, the lot date and this certificate's date).
"""

from __future__ import annotations

import datetime
import hashlib
from pathlib import Path


TRACE_TOP = 0.22  # the traceability table's top at the lowest (the key figures end above it)


def select(cols: list[str], rows: list[tuple], ref: str | None) -> list[int]:
    """The indices of the lot's items ``ref`` names (serial, item path or its last part, or
    ``#N`` the N-th item from 1); every item when ``ref`` is None."""
    from ares.errors import InputError

    if ref is None:
        return list(range(len(rows)))
    if ref.startswith("#") and ref[1:].isdigit() and 1 <= int(ref[1:]) <= len(rows):
        return [int(ref[1:]) - 1]
    s, it = cols.index("serial"), cols.index("item")
    hit = [i for i, r in enumerate(rows) if ref in (r[s], r[it], Path(r[it]).name)]
    if not hit:
        raise InputError(f"no item '{ref}' in the lot (give a serial, an item path or #N)")
    return hit


def _manifest_sha(run_dir: str) -> str:
    p = Path(run_dir or "") / "manifest.json"
    if run_dir and p.is_file():
        return hashlib.sha256(p.read_bytes()).hexdigest()
    return "not available (the run directory is not at hand here)" if run_dir else "not a run directory"


def _limit_cells(q: str, screens: list[dict], outcome: dict) -> tuple[str, str, str]:
    from ares.batch.vocabulary import canonical

    static, dynamic, verdicts = [], [], []
    for s in screens:
        if canonical(s["quantity"]) != q:
            continue
        if s["kind"] == "static":
            static.append(" and ".join(x for x in (f">= {s['low']:g}" if s["low"] is not None else "",
                                                   f"<= {s['high']:g}" if s["high"] is not None else "") if x))
        elif s["low"] is not None:
            dynamic.append(f"{s['low']:.5g} .. {s['high']:.5g} (k={s['k']:g})")
        else:
            dynamic.append("not set (too few items)")
        verdicts.append(outcome.get(s["screen"]) or "not tested")
    return "; ".join(static) or "none", "; ".join(dynamic) or "none", ", ".join(verdicts) or "-"


def pages(db, lot_id: int, which: list[int]):
    """The certificate pages (matplotlib figures) of the lot's items ``which``."""
    from ares import __version__
    from ares.report.page_tables import fmt_value
    from ares.batch import db as rdb
    from ares.batch.vocabulary import quantity_label
    from ares.report.plots import new_page, paginate, table_lines_between, text_table

    info = rdb.lot_info(db, lot_id)
    cols, rows = rdb.item_rows(db, lot_id)
    figs = rdb.figures(db, lot_id)
    screens = rdb.screens(db, lot_id)
    bins = rdb.bins(db, lot_id)
    today = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    out = []
    for i in which:
        r = dict(zip(cols, rows[i]))
        fig = new_page(f"Certificate of performance: {r['serial'] or Path(r['item']).name}",
                       f"lot {info['name']} (#{lot_id}), item {i + 1} of {len(rows)}")
        pos = "-" if r["x"] is None else f"x {r['x']:g}, y {r['y']:g}"
        b = bins.get(r["soft_bin"]) if r["soft_bin"] is not None else None
        ident = [["serial", r["serial"] or "-"], ["lot", info["name"]], ["wafer", r["wafer"] or "-"],
                 ["die position", pos], ["item", r["item"]], ["kind", r["kind"] or "-"],
                 ["verdict", r["verdict"]],
                 ["bin", "not binned (the lot sets no limits or screens)" if b is None
                  else f"hard {r['hard_bin']} ({b['hard_name']}, {'pass' if b['pass'] else 'fail'}), "
                       f"soft {r['soft_bin']}: {b['name']}"]]
        if r["error"]:
            ident.append(["error", r["error"]])
        y = text_table(fig, (0.06, 0.92, 0.88), ["identity", ""], ident, [0.22, 0.78], fontsize=8,
                       max_chars=[20, 110])
        rowsf = []
        for q, f in sorted(figs.get(i, {}).items(), key=lambda qf: quantity_label(qf[0]).lower()):
            st, dy, v = _limit_cells(q, screens, r)
            limit = f.get("verdict") in ("upper limit", "lower limit")  # "< x" / "> x": a limit has no SE
            val = fmt_value(f["value"], f["se"], f["unit"] or "", f.get("verdict") or "", f.get("exact", "")) \
                if f["value"] is not None else "not available"  # (an SE of 0: "exact: ...")
            se = "" if f["value"] is None or limit else ("SE not available" if f["se"] is None else "")
            rowsf.append([quantity_label(q), val + (f" ({se})" if se else ""), st, dy, v])
        head = ["quantity", "value ± SE, unit", "limit", "dynamic limit", "outcome"]
        w, mc = [0.3, 0.26, 0.16, 0.18, 0.1], [44, 34, 24, 28, 16]  # (34: the monospace value column's width)
        rowsf = rowsf or [["no figures", "", "", "", ""]]
        # every figure, each cell whole (wrapped): as many as fit above the traceability, the rest continued
        chunks = paginate(rowsf, mc, table_lines_between(y - 0.02, TRACE_TOP + 0.02, 6.5, True),
                          table_lines_between(0.92, 0.04, 6.5, False))
        y = text_table(fig, (0.06, y - 0.02, 0.88), head, chunks[0], w, fontsize=6.5,
                       title=f"Key figures ({len(rowsf)})", max_chars=mc, wrap=True)
        more = []
        for chunk in chunks[1:]:  # (a sensor with many figures: continued)
            cont = new_page(f"Certificate of performance: {r['serial'] or Path(r['item']).name} (continued)",
                            f"lot {info['name']} (#{lot_id}), item {i + 1} of {len(rows)}")
            text_table(cont, (0.06, 0.92, 0.88), head, chunk, w, fontsize=6.5, max_chars=mc, wrap=True)
            more.append(cont)
        trace = [["item measured", r["started"] or "-"], ["item ARES version", r["ares_version"] or "-"],
                 ["content hash (SHA-256)", r["content_hash"] or "-"],
                 ["run manifest (SHA-256)", _manifest_sha(r["run_dir"])],
                 ["lot written", f"{info['created']} by ARES {info['ares_version']}"],
                 ["certificate", f"{today} by ARES {__version__}"]]
        text_table(fig, (0.06, max(y - 0.02, TRACE_TOP), 0.88), ["traceability", ""], trace, [0.26, 0.74], fontsize=7,
                   title="Traceability", max_chars=[26, 100])
        out += [fig, *more]
    return out


def write(db, lot_id: int, which: list[int], path: Path) -> int:
    """The certificates as one PDF (a page a sensor; .tmp, renamed); the pages written."""
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    from ares.report.plots import RC
    from ares.rundir.files import storage

    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with storage(path), matplotlib.rc_context(RC), PdfPages(tmp) as pdf:
        n = 0
        for fig in pages(db, lot_id, which):
            pdf.savefig(fig)
            n += 1
    tmp.replace(path)
    return n
