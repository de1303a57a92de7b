"""The EMVA 1288 Release 4.0 datasheets, one per release (Linear, General), as PDF pages and
as JSON/CSV (Section 10.2 and its summary-sheet template, Appendix G; Table 1's mandatory
graphs). Each has its own summary sheet (General: its own Table 2, "cannot be measured"
where the text says so), footer, Section 10.1 block and operation point ("not given" where
nobody stated it); the Linear page 1 warns when the Eq. 51 check fails. The detail pages are
drawn by ``ares.report.datasheet_pages``.

Linear pages: the summary sheet of the operation point (header with vendor, model, serial and the
measurement date; the operation-point table; the photon transfer and SNR graphs; the
one-column table of Table 2 with every value's SE or verdict; the release in the footer),
then the detailed results, each graph with a table of the data it was read from: photon
transfer and linearity (Sections 6.6, 6.9), dark current (7.1, 7.2), spatial variances per
exposure step (4.3), spectrograms (8.6), profiles (8.7), logarithmic and accumulated
histograms (8.8), and for Release 4.0 General the characteristic curve, the input SNR and
the stability graph (General 6.6 - 6.8). The EMVA 1288 logo belongs to the EMVA and is not
reproduced: its place in the header holds the text "EMVA 1288".
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import matplotlib
from matplotlib.figure import Figure

from ares.analysis.emva.sheet import SYMBOLS, symbol
from ares.analysis.stats.estimate import exact_text, note_text
from ares.report import datasheet_pages as dp
from ares.report.datasheet_pages import GENERAL, LINEAR, given, value_text
from ares.report.plots import A4, RC

GROUPS = (("Quantum efficiency", ("QE",)), ("Overall system gain", ("K", "K_inv")),
          ("Temporal dark noise", ("sigma_d", "sigma_y_dark")),
          ("Signal-to-noise ratio", ("SNR_max", "SNR_max_db", "SNR_max_inv")),
          ("Absolute sensitivity threshold", ("mu_e_min", "mu_e_min_area")),
          ("Saturation capacity", ("mu_e_sat", "mu_e_sat_area")), ("Dynamic range", ("DR", "DR_db")),
          ("Spatial nonuniformities", ("DSNU1288", "DSNU1288_col", "DSNU1288_row", "DSNU1288_pix", "PRNU1288",
                                       "PRNU1288_col", "PRNU1288_row", "PRNU1288_pix")),
          ("Linearity error", ("LE",)), ("Dark current", ("mu_I_mean", "mu_I_var")))


def rows(sheet, general=None) -> list[dict]:
    """One row per published quantity: name, symbol, value, SE, unit, verdict, definition."""
    out = []
    for k, e in sheet.values.items():
        d = e.to_dict()
        out.append({"release": sheet.release, "quantity": k, "symbol": SYMBOLS.get(k, k), "value": d["value"],
                    "se": d["se"], "unit": e.unit, "verdict": d["verdict"], "definition": note_text(d)})
    if general is not None:
        for k, e in general.values.items():
            d = e.to_dict()
            out.append({"release": "EMVA 1288 Release 4.0 General", "quantity": k, "symbol": symbol(k, True), "value": d["value"],
                        "se": d["se"], "unit": e.unit, "verdict": d["verdict"], "definition": note_text(d)})
    return out


CSV_COLUMNS = ["release", "quantity", "symbol", "value", "se", "unit", "verdict", "definition"]


def _csv(rows_: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, CSV_COLUMNS)
    w.writeheader()
    for r in rows_:
        w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    return buf.getvalue()


def to_csv(sheet, general=None) -> str:
    return _csv(rows(sheet, general))


def values_csv(release: str, values: dict, shown: dict) -> str:
    """A release's figures (``values``: key -> Estimate) as the same CSV, in the order and
    with the keys of its --json (``shown``): ``ares emva --release 3.0/3.1 --csv``."""
    out = []
    for k in shown:
        e = values[k]
        d = e.to_dict()
        out.append({"release": release, "quantity": k, "symbol": k, "value": d["value"], "se": d["se"],
                    "unit": e.unit, "verdict": d["verdict"], "definition": note_text(d)})
    return _csv(out)


# ------------------------------------------------------------------ pages

# ------------------------------------------------------------------ page 1 and Section 10.1

def _op_table(fig: Figure, m: dict, top: float) -> float:
    left = [("Type of data", given(m, "type_of_data")), ("Exposure control", given(m, "exposure_control")),
            ("Exposure time", given(m, "exposure_time")), ("Frame rate", given(m, "frame_rate")),
            ("Data transfer mode", given(m, "data_mode"))]
    right = [("Gain, black level", given(m, "gain_black_level")),
             ("Environmental temperature", given(m, "env_temperature")),
             ("Camera body temperature", given(m, "body_temperature")),
             ("Internal temperature(s)", given(m, "internal_temperature")),
             ("Wavelength, centr., FWHM", given(m, "wavelength"))]
    y = top
    for (a, b), (c, d) in zip(left, right):
        fig.text(0.06, y, a, fontsize=7.2, va="top")
        fig.text(0.25, y, b[:48], fontsize=7.2, va="top")
        fig.text(0.55, y, c, fontsize=7.2, va="top")
        fig.text(0.76, y, d[:30], fontsize=7.2, va="top")
        y -= 0.0135
    return y


def linear_warning(sheet) -> str | None:
    """Page 1's warning when the Eq. 51 check finds the linear model does not hold."""
    if getattr(sheet.photon_transfer, "linear", None) is not False:
        return None
    why = next((n for n in sheet.photon_transfer.notes if "51" in n), "")
    return ("WARNING: the linear model does not hold by the Eq. 51 local-slope check" + (f" ({why})" if why else "")
            + ". The Release 4.0 Linear figures below assume it; characterize this camera by EMVA 1288 "
              "Release 4.0 General instead (ares emva --release 4.0-general).")


def _warning(fig: Figure, text: str | None, y: float) -> float:
    import textwrap

    if not text:
        return y
    for w in textwrap.wrap(text, 132):
        fig.text(0.06, y, w, fontsize=6.6, color="C3", weight="bold", va="top")
        y -= 0.011
    return y - 0.002


def _table_column(fig: Figure, groups, values: dict, y: float) -> float:
    for title, keys in groups:
        fig.text(0.64, y, title, fontsize=7.5, weight="bold", va="top")
        y -= 0.0145
        for k in keys:
            e = values.get(k)
            if e is None:
                continue
            fig.text(0.645, y, SYMBOLS.get(k, k)[:16], fontsize=7.0, va="top")
            y = _value_cell(fig, y, e, 7.0, 0.013)
        y -= 0.004
    return y


def _value_cell(fig: Figure, y: float, e, size: float, step: float) -> float:
    """A summary-sheet value right-aligned at ``y`` (never cut -- R_d's unit was: a long one in a
    smaller font), an exact value's verdict on the line below; the y of the next row."""
    txt = cell(e, with_exact=False)
    fig.text(0.95, y, txt, fontsize=size if len(txt) <= 26 else size * 26 / len(txt), va="top", ha="right",
             family="monospace")
    if e.available and e.is_exact:
        y -= step * 0.9
        fig.text(0.95, y, f"({exact_text(e.exact)})", fontsize=size - 0.8, va="top", ha="right", color="0.25")
    return y - step


def cell(e, with_exact: bool = True) -> str:
    """A summary-sheet value: the figure with its unit (and an exact one's verdict), or why there is none."""
    return e.text(with_exact=with_exact) if e.available else value_text(e)


def _snr_height(top: float) -> float:
    """The lower plot's height: below the upper plot (its bottom at ``top - 0.33``) with room
    for that plot's axis label and its own title (a warning above pushed them onto each other)."""
    return min(0.34, top - 0.33 - 0.075 - 0.09)


def summary_page(sheet) -> Figure:
    fig = Figure(figsize=A4)
    m = sheet.meta
    wl = m.get("wavelength_nm")
    dp._header(fig, sheet, "Summary Sheet for Operation Point 1" + (f" at a Wavelength of {wl:g} nm" if wl else ""),
               "page 1", LINEAR)
    y = _op_table(fig, m, 0.93)
    y = _warning(fig, linear_warning(sheet), y - 0.002)
    top = min(0.83, y - 0.01)
    a1 = fig.add_axes([0.09, top - 0.33, 0.50, 0.30])
    dp._ptc_axes(a1, sheet)
    a2 = fig.add_axes([0.09, 0.09, 0.50, _snr_height(top)])
    dp._snr_axes(a2, sheet)
    y = _table_column(fig, GROUPS, sheet.values, top)
    fig.text(0.64, y - 0.004, "Values with their standard error; '<' / '>' mark limits; n/a: see the notes page.",
             fontsize=5.8, color="0.35", va="top", wrap=True)
    return fig


def general_summary_page(sheet, general) -> Figure:
    """The Release 4.0 General summary sheet: its own values (every entry of the result, in
    order), "cannot be measured" where the text says so, no K, η or electrons."""
    fig = Figure(figsize=A4)
    m = sheet.meta
    wl = m.get("wavelength_nm")
    dp._header(fig, sheet, "Summary Sheet (Release 4.0 General) for Operation Point 1" +
               (f" at {wl:g} nm" if wl else ""), "page 1", GENERAL)
    y = _op_table(fig, m, 0.93)
    top = min(0.83, y - 0.01)
    if general is not None and general.curve is not None:
        dp.general_curve_axes(fig.add_axes([0.09, top - 0.33, 0.50, 0.30]), general)
        dp.general_snr_axes(fig.add_axes([0.09, 0.09, 0.50, _snr_height(top)]), general)
    values = general.values if general is not None else {}
    y = top
    fig.text(0.64, y, "Release 4.0 General, Table 2", fontsize=7.5, weight="bold", va="top")
    y -= 0.0155
    for k, e in values.items():
        fig.text(0.645, y, symbol(k, True)[:18], fontsize=6.6, va="top")
        y = _value_cell(fig, y, e, 6.6, 0.0118)
        if y < 0.06:
            break
    fig.text(0.64, y - 0.004, "General model: K, η and values in electrons are not defined (General Section 6.7).",
             fontsize=5.8, color="0.35", va="top", wrap=True)
    return fig


BASIC = (("Vendor", "vendor"), ("Model", "model"), ("Serial number", "serial"), ("Type of data presented", "type_of_data"),
         ("Sensor type", "sensor_type"), ("Sensor diagonal", "sensor_diagonal"), ("Lens category", "lens_category"),
         ("Resolution", "resolution"), ("Pixel size", "pixel_size"), ("Readout type (CCD)", "readout_type"),
         ("Transfer type (CCD)", "transfer_type"), ("Shutter type (CMOS)", "shutter_type"),
         ("Overlap capabilities (CMOS)", "overlap"), ("Maximum readout rate", "max_readout_rate"),
         ("Dark current compensation", "dark_current_compensation"), ("Interface type", "interface"))


def _resolution(sheet) -> str | None:
    c = sheet.curves
    if "profile_dsnu_h" in c and "profile_dsnu_v" in c:  # the stack images' width and height
        return f"{len(c['profile_dsnu_h']['mean'])} x {len(c['profile_dsnu_v']['mean'])} pixels"
    return None


def basic_information_page(sheet, rel: str) -> Figure:
    """Linear/General Section 10.1: the basic information that precedes the EMVA 1288 data."""
    import textwrap

    m = dict(sheet.meta)
    m.setdefault("resolution", _resolution(sheet))
    if not m.get("pixel_size"):  # the per-area values were divided by a pixel area: say which
        import re

        area = next((float(x.group(1)) for e in sheet.values.values()
                     for x in [re.search(r"pixel area \(([0-9.]+) µm²\)", str(e.note))] if x), None)
        if area:
            m["pixel_size"] = f"{area ** 0.5:.3g} µm (pixel area {area:g} µm², as the per-area values use)"
    fig = Figure(figsize=A4)
    dp._header(fig, sheet, "Basic information (Section 10.1) and operation point", "basic information", rel)
    y = 0.91
    op = "; ".join(f"{a}: {given(m, k)}" for a, k in (("exposure control", "exposure_control"),
                                                       ("exposure time", "exposure_time"),
                                                       ("gain, black level", "gain_black_level"),
                                                       ("data mode", "data_mode"), ("wavelength", "wavelength")))
    items = [(a, given(m, k)) for a, k in BASIC]
    items += [("Operation point(s)", op + " (parameters not given are the factory default)"),
              ("EMVA 1288", f"{rel}; data: {given(m, 'source')}; test equipment: {given(m, 'equipment')}")]
    for a, b in items:
        fig.text(0.06, y, a, fontsize=7.5, weight="bold", va="top")
        for w in textwrap.wrap(b, 95) or [""]:
            fig.text(0.34, y, w, fontsize=7.5, va="top")
            y -= 0.0145
        y -= 0.003
    return fig


def notes_page(sheet, general=None, rel: str = LINEAR) -> Figure:
    import textwrap

    fig = Figure(figsize=A4)
    dp._header(fig, sheet, "Measurement, release and notes", "notes", rel)
    y = 0.91
    lines = [f"Release used for the analysis: {rel}", f"Measurement date: {given(sheet.meta, 'date')}",
             f"Data: {given(sheet.meta, 'source')}"]
    if rel == GENERAL and general is not None:
        lines += [f"Saturation: {general.saturation}"] + [f"Note: {n}" for n in general.notes]
        na = [f"  {symbol(k, True)}: {e.text()} — {e.note}" for k, e in general.values.items() if not e.available or e.bound]
        lines += (["Values that are not available, limits, or cannot be measured:"] + na) if na else []
    else:
        lines += [f"Saturation: {sheet.photon_transfer.saturation}"] + [f"Note: {n}" for n in sheet.notes]
        na = [f"  {SYMBOLS.get(k, k)}: {e.text()} — {e.note}" for k, e in sheet.values.items()
              if not e.available or e.bound]
        lines += (["Not available values and limits:"] + na) if na else []  # no heading over nothing
    for ln in lines:
        for w in textwrap.wrap(ln, 120, subsequent_indent="    ") or [""]:
            fig.text(0.06, y, w, fontsize=7.3, va="top")
            y -= 0.0145
            if y < 0.05:
                return fig
    return fig


def pages(sheet, general=None, release: str = "4.0-linear") -> list[tuple[str, Figure]]:
    """The pages of the datasheet of ``release`` ("4.0-linear" or "4.0-general"), each with
    its own summary sheet, Section 10.1 block, graphs and footer."""
    rel = GENERAL if release == "4.0-general" else LINEAR
    if rel == GENERAL:
        out = [("EMVA General summary", general_summary_page(sheet, general)),
               ("EMVA basic information", basic_information_page(sheet, rel))]
        out += [("EMVA general", f) for f in dp.general_pages(sheet, general, rel)]
    else:
        out = [("EMVA summary", summary_page(sheet)), ("EMVA basic information", basic_information_page(sheet, rel)),
               ("EMVA photon transfer", dp.photon_transfer_page(sheet, rel)),
               ("EMVA linearity", dp.linearity_page(sheet, rel)),
               ("EMVA dark current", dp.dark_current_page(sheet, rel)),
               ("EMVA values", dp.values_page(sheet, sheet.values, "Release 4.0 Linear: every value with its "
                                              "definition", "values", rel))]
    for title, fn in (("EMVA spatial variances", dp.spatial_steps_page), ("EMVA spectrograms", dp.spectrogram_page),
                      ("EMVA profiles", dp.profiles_page), ("EMVA histograms", dp.histogram_page)):
        f = fn(sheet, rel)
        if f is not None:
            out.append((title, f))
    out.append(("EMVA notes", notes_page(sheet, general, rel)))
    return out


def write_datasheet(sheet, path: str | Path, general=None, release: str = "4.0-linear") -> list[str]:
    """The datasheet PDF of ``release`` at ``path`` (written to a temporary name, then renamed)."""
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    rel = GENERAL if release == "4.0-general" else LINEAR
    with matplotlib.rc_context(RC):
        pg = pages(sheet, general, release)
        with PdfPages(tmp, metadata={"Title": f"EMVA 1288 datasheet ({rel})", "Creator": "ares"}) as pdf:
            for _, fig in pg:
                pdf.savefig(fig)
    tmp.replace(path)
    return [t for t, _ in pg]
