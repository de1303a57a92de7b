"""The EMVA 1288 Release 4.0 datasheet as PDF pages and as JSON/CSV (Linear Section 10.2 and
its summary-sheet template, Appendix G; Table 1's mandatory graphs).

Pages: the summary sheet of the operation point (header with vendor, model, serial and the
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
import math
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from ares.analysis.emva4_sheet import EXTRA, SYMBOLS, TABLE2
from ares.analysis.emva_graphs import pattern_amplitude
from ares.report.plots import A4, RC, text_table

GROUPS = (("Quantum efficiency", ("QE",)), ("Overall system gain", ("K", "K_inv")),
          ("Temporal dark noise", ("sigma_d", "sigma_y_dark")),
          ("Signal-to-noise ratio", ("SNR_max", "SNR_max_db", "SNR_max_inv")),
          ("Absolute sensitivity threshold", ("mu_e_min", "mu_e_min_area")),
          ("Saturation capacity", ("mu_e_sat", "mu_e_sat_area")), ("Dynamic range", ("DR", "DR_db")),
          ("Spatial nonuniformities", ("DSNU1288", "DSNU1288_col", "DSNU1288_row", "DSNU1288_pix", "PRNU1288",
                                       "PRNU1288_col", "PRNU1288_row", "PRNU1288_pix")),
          ("Linearity error", ("LE",)), ("Dark current", ("mu_I_mean", "mu_I_var")))
UNITS = {k: u for k, _, u in TABLE2 + EXTRA}


def value_text(e) -> str:
    return e.text(with_unit=False) if e.available else "n/a"


def rows(sheet, general=None) -> list[dict]:
    """One row per published quantity: name, symbol, value, SE, unit, verdict, definition."""
    out = []
    for k, e in sheet.values.items():
        d = e.to_dict()
        out.append({"release": sheet.release, "quantity": k, "symbol": SYMBOLS.get(k, k), "value": d["value"],
                    "se": d["se"], "unit": e.unit, "verdict": d["verdict"], "definition": e.note})
    if general is not None:
        for k, e in general.values.items():
            d = e.to_dict()
            out.append({"release": "EMVA 1288 Release 4.0 General", "quantity": k, "symbol": k, "value": d["value"],
                        "se": d["se"], "unit": e.unit, "verdict": d["verdict"], "definition": e.note})
    return out


def to_csv(sheet, general=None) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, ["release", "quantity", "symbol", "value", "se", "unit", "verdict", "definition"])
    w.writeheader()
    for r in rows(sheet, general):
        w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    return buf.getvalue()


# ------------------------------------------------------------------ pages

def _header(fig: Figure, sheet, title: str, page: str) -> None:
    m = sheet.meta
    fig.text(0.05, 0.975, "EMVA 1288", fontsize=13, weight="bold", va="top")
    ident = ", ".join(str(m.get(k) or f"[{k}]") for k in ("vendor", "model", "serial")) + \
        f", measurement date: {m.get('date') or '[date]'}"
    fig.text(0.95, 0.975, ident, fontsize=8, ha="right", va="top")
    fig.text(0.5, 0.948, title, fontsize=11.5, weight="bold", ha="center", va="top")
    fig.text(0.05, 0.012, str(m.get("footer") or m.get("source") or ""), fontsize=6.5, color="0.4")
    fig.text(0.95, 0.012, f"{sheet.release} · {page}", fontsize=7, ha="right", color="0.3")


def _op_table(fig: Figure, m: dict, top: float) -> float:
    def g(k, unit=""):
        v = m.get(k)
        return "—" if v in (None, "") else (f"{v:g}{unit}" if isinstance(v, (int, float)) else str(v))
    left = [("Type of data", g("type_of_data")), ("Exposure control", g("exposure_control")),
            ("Exposure time", g("exposure_time")), ("Frame rate", g("frame_rate")),
            ("Data transfer mode", g("data_mode"))]
    right = [("Gain, black level", g("gain_black_level")), ("Environmental temperature", g("env_temperature")),
             ("Camera body temperature", g("body_temperature")), ("Internal temperature(s)", g("internal_temperature")),
             ("Wavelength, centr., FWHM", g("wavelength"))]
    y = top
    for (a, b), (c, d) in zip(left, right):
        fig.text(0.06, y, a, fontsize=7.5, va="top")
        fig.text(0.30, y, b, fontsize=7.5, va="top")
        fig.text(0.52, y, c, fontsize=7.5, va="top")
        fig.text(0.78, y, d, fontsize=7.5, va="top")
        y -= 0.014
    return y


def _shown(sheet, key: str) -> str:
    """A figure's text for a title, "not available" where the evaluation stopped before it."""
    e = sheet.values.get(key)
    return e.text() if e is not None else "not available"


def _ptc_axes(ax, sheet, large: bool = False) -> None:
    c = sheet.curves
    v, sig = c["var"], c["signal"]
    fit = np.asarray(c["fit_levels"], int)
    K = sheet.values["K"]
    ax.plot(sig, v, "o", ms=3 if large else 2.5, color="C0", label="mono data")
    if fit.size and K.available:
        xs = np.array([0.0, float(sig[fit].max())])
        off = float(np.mean(v[fit] - K.value * sig[fit]))
        ax.plot(xs, off + K.value * xs, "-", color="C1", label="mono fit (0 - 70 % sat.)")
    if c.get("index_sat") is not None:
        ax.axvline(sig[c["index_sat"]], ls="--", color="0.4", lw=0.8, label="saturation")
    dark0 = float(np.min(c["dark_s2"])) if np.size(c["dark_s2"]) else math.nan
    ax.text(0.03, 0.95, f"var(dark) = {dark0:.3g} DN², K = {K.text()}", transform=ax.transAxes, fontsize=7, va="top")
    ax.set(xlabel="mean − dark value (DN)", ylabel="variance − dark variance (DN²)", title="Photon transfer")
    ax.legend(fontsize=6.5, loc="lower right")


def _snr_axes(ax, sheet) -> None:
    c = sheet.curves
    x = c["photons"]
    top = c.get("index_sat")
    below = np.arange(x.size) <= (top if top is not None else x.size)  # clipped levels are not drawn
    ok = below & (x > 0) & np.isfinite(c["snr"]) & (c["snr"] > 0)
    ax.loglog(x[ok], c["snr"][ok], "o", ms=2.5, color="C0", label="mono data")
    if "snr_total" in c:
        okt = ok & np.isfinite(c["snr_total"]) & (c["snr_total"] > 0)
        ax.loglog(x[okt], c["snr_total"][okt], "^", ms=2.5, color="C2", label="mono data total")
    if "model_photons" in c:
        g = c["model_photons"]
        ax.loglog(g, c["snr_model"], "-", color="C1", label="mono fit")
        if "snr_total_model" in c:
            ax.loglog(g, c["snr_total_model"], "--", color="C2", label="mono fit total")
        ax.loglog(g, c["snr_ideal"], ":", color="0.3", label="theor. limit")
    ax.axhline(1.0, color="0.6", lw=0.7)
    ax.text(0.02, 0.1, "threshold SNR = 1", transform=ax.transAxes, fontsize=6.5, color="0.4")
    for key, lab in (("mu_p_min", "threshold"), ("mu_p_sat", "saturation")):
        e = sheet.values.get(key)
        if e is not None and e.available:
            ax.axvline(e.value, ls="--", color="0.4", lw=0.8)
            ax.text(e.value, 0.97, " " + lab, transform=ax.get_xaxis_transform(), fontsize=6.5, va="top",
                    rotation=90, color="0.3")
    ax.set(xlabel="irradiation (photons/pixel)", ylabel="SNR", title="Signal-to-noise ratio")
    ax.legend(fontsize=6.5, loc="lower right")


def summary_page(sheet) -> Figure:
    fig = Figure(figsize=A4)
    m = sheet.meta
    wl = m.get("wavelength_nm")
    _header(fig, sheet, "Summary Sheet for Operation Point 1" + (f" at a Wavelength of {wl:g} nm" if wl else ""),
            "page 1")
    _op_table(fig, m, 0.925)
    a1 = fig.add_axes([0.09, 0.50, 0.50, 0.32])
    _ptc_axes(a1, sheet)
    a2 = fig.add_axes([0.09, 0.09, 0.50, 0.34])
    _snr_axes(a2, sheet)
    y = 0.83
    for title, keys in GROUPS:
        fig.text(0.64, y, title, fontsize=7.5, weight="bold", va="top")
        y -= 0.0145
        for k in keys:
            e = sheet.values.get(k)
            if e is None:
                continue
            fig.text(0.645, y, SYMBOLS.get(k, k), fontsize=7.2, va="top")
            unit = " " + UNITS[k] if UNITS[k] else ""
            fig.text(0.93, y, value_text(e) + (unit if e.available else ""), fontsize=7.2, va="top",
                     ha="right", family="monospace")
            y -= 0.0135
        y -= 0.004
    fig.text(0.64, y - 0.004, "Values with their standard error; '<' / '>' mark limits; n/a: see the notes page.",
             fontsize=5.8, color="0.35", va="top", wrap=True)
    return fig


def _data_table(fig, top, header, data, widths, title=""):
    return text_table(fig, (0.08, top, 0.84), header, data, widths, fontsize=6.8, title=title)


def photon_transfer_page(sheet) -> Figure:
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Sensitivity, linearity and noise (Sections 6.6, 6.9)", "photon transfer")
    c = sheet.curves
    a = fig.add_axes([0.1, 0.68, 0.8, 0.23])
    _ptc_axes(a, sheet, large=True)
    b = fig.add_axes([0.1, 0.43, 0.37, 0.19])
    x, sig = c["photons"], c["signal"]
    le = np.asarray(c["le_levels"], int)
    b.plot(x, sig, "o", ms=2, color="0.6", label="mono data")
    if le.size:
        b.plot(x[le], sig[le], "o", ms=2.5, color="C0", label="5 - 95 % sat.")
    b.set(xlabel="irradiation (photons/pixel)", ylabel="mean − dark (DN)", title="Characteristic curve")
    b.legend(fontsize=6)
    d = fig.add_axes([0.58, 0.43, 0.34, 0.19])
    dev = c["deviation_pct"]
    okd = np.isfinite(dev)
    d.plot(x[okd], dev[okd], "o-", ms=2.5, lw=0.6, color="C0")
    d.axhline(0, color="0.5", lw=0.6)
    d.set(xlabel="irradiation (photons/pixel)", ylabel="deviation (%)",
          title=f"Linearity error LE = {_shown(sheet, 'LE')}")
    n = len(x)
    pick = np.unique(np.linspace(0, n - 1, min(n, 18)).round().astype(int))
    data = [[str(i), f"{x[i]:.4g}", f"{sig[i]:.4g}", f"{c['var'][i]:.4g}", f"{c['snr'][i]:.3g}",
             "fit" if i in set(c["fit_levels"]) else "", "" if not np.isfinite(dev[i]) else f"{dev[i]:+.2f}"]
            for i in pick]
    _data_table(fig, 0.37, ["step", "µp (photons)", "µy − µy.dark (DN)", "σ²y − σ²y.dark (DN²)", "SNR", "K fit",
                            "δy (%)"], data, [0.6, 1.2, 1.4, 1.5, 0.9, 0.6, 0.8],
                title=f"Extracted data ({len(pick)} of {n} steps; all in the CSV)")
    return fig


def dark_current_page(sheet) -> Figure:
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Dark current (Section 7)", "dark current")
    c = sheet.curves
    t, mu, s2 = c["dark_t"], c["dark_mu"], c["dark_s2"]
    for k, (y, lab, key) in enumerate(((mu, "mean dark signal (DN)", "mu_I_mean"),
                                       (s2, "variance dark signal (DN²)", "mu_I_var"))):
        ax = fig.add_axes([0.1 + 0.45 * k, 0.62, 0.36, 0.27])
        ax.plot(t, y, "o", ms=3, label="mono data")
        if np.unique(t).size >= 2:
            p = np.polyfit(t, y, 1)
            ts = np.array([t.min(), t.max()])
            ax.plot(ts, np.polyval(p, ts), "-", label="mono fit")
        ax.set(xlabel="exposure time (s)", ylabel=lab, title=f"{SYMBOLS[key]} = {_shown(sheet, key)}")
        ax.legend(fontsize=6.5)
    y = 0.54
    temps = c.get("dark_vs_temperature")
    if temps:
        ax = fig.add_axes([0.1, 0.30, 0.8, 0.2])
        T = [a for a, e in temps if e.available]
        v = [e.value for a, e in temps if e.available]
        ax.semilogy(T, v, "o-")
        ax.set(xlabel="temperature (°C)", ylabel="dark current (e-/s)", title="Dark current vs temperature (7.2)")
        y = 0.25
    pick = np.unique(np.linspace(0, t.size - 1, min(t.size, 16)).round().astype(int))
    _data_table(fig, y, ["exposure (s)", "µy.dark (DN)", "σ²y.dark (DN²)"],
                [[f"{t[i]:.5g}", f"{mu[i]:.5g}", f"{s2[i]:.4g}"] for i in pick], [1, 1, 1],
                title="Extracted data")
    return fig


def spatial_steps_page(sheet) -> Figure | None:
    c = sheet.curves
    if "step_s2_bright_total" not in c:
        return None
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Spatial variances at every exposure step (Sections 4.2, 4.3)", "spatial variances")
    sig = c["signal"]
    ax = fig.add_axes([0.1, 0.55, 0.8, 0.33])
    for part, col in (("total", "k"), ("col", "C0"), ("row", "C1"), ("pix", "C2")):
        y = c[f"step_s2_bright_{part}"] - c[f"step_s2_dark_{part}"]
        ok = (y > 0) & (sig > 0)
        ax.loglog(sig[ok], np.sqrt(y[ok]) / sig[ok] * 100, "o", ms=2.5, color=col, label=f"PRNU {part}")
    ax.set(xlabel="mean − dark value (DN)", ylabel="spatial std / signal (%)",
           title="Photoresponse nonuniformity from two images per step (high-passed)")
    ax.legend(fontsize=6.5)
    bx = fig.add_axes([0.1, 0.12, 0.8, 0.33])
    for part, col in (("total", "k"), ("col", "C0"), ("row", "C1"), ("pix", "C2")):
        y = c[f"step_s2_dark_{part}"]
        ok = y > 0
        bx.plot(c["photons"][ok], np.sqrt(y[ok]), "o", ms=2.5, color=col, label=f"dark {part}")
    bx.set(xlabel="irradiation of the step (photons/pixel)", ylabel="spatial std (DN)",
           title="Dark signal nonuniformity at each step's exposure")
    bx.legend(fontsize=6.5)
    return fig


def _panel(fig: Figure, k: int):
    """The k-th of four stacked full-width graphs of a detail page."""
    return fig.add_axes([0.1, 0.785 - 0.185 * k, 0.8, 0.115])  # a table of the extracted data fits below


def spectrogram_page(sheet) -> Figure | None:
    c = sheet.curves
    if "spectrogram_dsnu_h" not in c:
        return None
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Horizontal and vertical spectrograms (Section 8.6)", "spectrograms")
    specs = [("spectrogram_dsnu_h", "DSNU, horizontal", "dark_lines", "DN"),
             ("spectrogram_dsnu_v", "DSNU, vertical", "dark_lines", "DN"),
             ("spectrogram_prnu_h", "PRNU, horizontal", "prnu_lines", "%"),
             ("spectrogram_prnu_v", "PRNU, vertical", "prnu_lines", "%")]
    for k, (key, title, lines, unit) in enumerate(specs):
        if key not in c:
            continue
        ax = _panel(fig, k)
        s = c[key]
        ax.semilogy(s.freq[1:], np.maximum(s.sqrt_power[1:], 1e-6), lw=0.6, color="C0", label="mono data")
        ln = c[lines]
        for name, val, style in ((("DSNU1288" if "dsnu" in key else "PRNU1288"),
                                  ln.get("DSNU1288", ln.get("PRNU1288")), "--"),
                                 ("σy.stack (single image)", ln["sigma_y_stack"], ":")):
            if val is not None and np.isfinite(val) and val > 0:
                ax.axhline(val, ls=style, color="C1" if style == "--" else "C2", lw=0.9, label=name)
        ax.set(xlabel="cycles (periods/pixel)", ylabel=f"standard deviation ({unit})", title=title, xlim=(0, 0.5))
        ax.legend(fontsize=6)
    rows = []
    for key, title, _, unit in specs:
        if key not in c:
            continue
        sp = c[key]
        p = sp.sqrt_power**2
        n = 2 * (p.size - 1)  # the row length of the spectrum
        for v in sorted(np.argsort(p[1:])[::-1][:2] + 1):  # the two strongest peaks (v >= 1)
            rows.append([title, f"{sp.freq[v]:.4f}", f"{sp.sqrt_power[v]:.3g}", f"{pattern_amplitude(p, n, v, v):.3g}",
                         unit])
    _data_table(fig, 0.165, ["spectrogram", "cycles/pixel", "sqrt(P)", "amplitude (Eq. 72)", "unit"], rows,
                [1.6, 1, 1, 1.2, 0.5], title="Strongest peaks")
    return fig


def profiles_page(sheet) -> Figure | None:
    c = sheet.curves
    if "profile_dsnu_h" not in c:
        return None
    from ares.analysis.emva_graphs import profile_range

    fig = Figure(figsize=A4)
    _header(fig, sheet, "Horizontal and vertical profiles, not high-pass filtered (Section 8.7)", "profiles")
    specs = [("profile_dsnu_h", "DSNU, horizontal (index = column)", "dsnu"),
             ("profile_dsnu_v", "DSNU, vertical (index = row)", "dsnu"),
             ("profile_prnu_h", "PRNU, horizontal (index = column)", "prnu"),
             ("profile_prnu_v", "PRNU, vertical (index = row)", "prnu")]
    for k, (key, title, kind) in enumerate(specs):
        if key not in c:
            continue
        ax = _panel(fig, k)
        p = c[key]
        for name, col in (("mean", "C0"), ("middle", "C1"), ("max", "C3"), ("min", "C2")):
            ax.plot(p[name], lw=0.5, color=col, label=name)
        ax.set_ylim(*profile_range(p, kind))
        ax.set(xlabel="index (pixel)", ylabel="gray value (DN)", title=title)
        ax.legend(fontsize=6, ncol=4)
    rows = [[title, f"{c[key]['mean'].mean():.5g}", f"{c[key]['middle'].mean():.5g}", f"{c[key]['min'].min():.5g}",
             f"{c[key]['max'].max():.5g}"] for key, title, _ in specs if key in c]
    _data_table(fig, 0.165, ["profile", "mean (DN)", "middle line mean", "lowest min", "highest max"], rows,
                [2.2, 1, 1.1, 1, 1], title="Extracted data")
    return fig


def histogram_page(sheet) -> Figure | None:
    c = sheet.curves
    if "hist_dsnu" not in c:
        return None
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Defect pixel characterization (Section 8.8)", "histograms")
    k = 0
    for kind in ("dsnu", "prnu"):
        h = c.get(f"hist_{kind}")
        if h is None:
            continue
        ax = _panel(fig, k)
        k += 1
        pos = h.counts > 0
        ax.semilogy(h.centers[pos], h.counts[pos], ".", ms=3, color="C0", label="mono data")
        ax.semilogy(h.centers, np.maximum(h.model, 1e-3), "--", color="C1", lw=0.8, label=f"normal, s = {h.sigma:.3g} DN")
        ax.set_ylim(0.3, max(float(h.counts.max()) * 3, 10))
        ax.set(xlabel=f"deviation from {'dark value' if kind == 'dsnu' else 'mean'} (DN)", ylabel="pixels/bin",
               title=f"Logarithmic histogram {kind.upper()} (bin width {h.width:.3g} DN)")
        ax.legend(fontsize=6)
    for kind in ("dsnu", "prnu"):
        a = c.get(f"acc_{kind}")
        if a is None:
            continue
        ax = _panel(fig, k)
        k += 1
        pos = a.count > 0
        ax.semilogy(a.deviation[pos], a.percent[pos], "-", lw=0.9, color="C0")
        ax.set_ylim(min(0.5 * 100 / max(a.count[0], 1), 1e-3), 150)
        ax.set(xlabel="deviation from mean (DN)", ylabel="percentage of pixels",
               title=f"Accumulated log histogram {kind.upper()}")
    rows = []
    for kind in ("dsnu", "prnu"):
        h, a = c.get(f"hist_{kind}"), c.get(f"acc_{kind}")
        if h is None or a is None or h.sigma <= 0:
            continue
        cnt = [int(a.count[np.searchsorted(a.deviation, m * h.sigma)]) if m * h.sigma <= a.deviation[-1] else 0
               for m in (3, 5, 10)]
        rows.append([kind.upper(), f"{h.sigma:.3g}", f"{h.width:.3g}", *map(str, cnt), str(int(a.count[0]))])
    _data_table(fig, 0.165, ["image", "s (DN)", "bin width (DN)", "pixels > 3 s", "> 5 s", "> 10 s", "pixels"],
                rows, [0.8, 0.8, 1, 1, 0.8, 0.8, 0.8], title="Pixels deviating from the mean (accumulated histogram)")
    return fig


def general_pages(sheet, general) -> list[Figure]:
    if general is None or general.curve is None:
        return []
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Release 4.0 General: characteristic curve and input SNR (General 6.6 - 6.8)", "general")
    g = general
    x = g.photons
    a = fig.add_axes([0.1, 0.68, 0.8, 0.22])
    a.plot(x, g.signal, "o", ms=2.5, label="mono data")
    xs = np.linspace(0, g.curve.x_max, 300)
    a.plot(xs, g.curve(xs), "-", lw=0.9, label=f"cubic B-spline, {g.curve.P} intervals")
    a.set(xlabel="irradiation (photons/pixel)", ylabel="mean − dark value (DN)", title="Characteristic curve")
    a.legend(fontsize=6.5)
    b = fig.add_axes([0.1, 0.38, 0.8, 0.22])
    below = np.arange(x.size) <= (g.index_sat if g.index_sat is not None else x.size)  # clipped steps not drawn
    ok = below & np.isfinite(g.snr_p) & (g.snr_p > 0) & (x > 0)
    b.loglog(x[ok], g.snr_p[ok], "o", ms=2.5, label="input SNR_p (Eq. 10)")
    oky = below & np.isfinite(g.snr_y) & (g.snr_y > 0) & (x > 0)
    b.loglog(x[oky], g.snr_y[oky], "^", ms=2.5, label="output SNR_y (Eq. 7)")
    b.loglog(x[x > 0], np.sqrt(x[x > 0]), ":", color="0.3", label="ideal sensor (Eq. 15)")
    b.axhline(1, color="0.6", lw=0.7)
    b.set(xlabel="irradiation (photons/pixel)", ylabel="SNR", title="Input SNR")
    b.legend(fontsize=6.5)
    s = fig.add_axes([0.1, 0.08, 0.8, 0.22])
    s.plot(g.signal, g.sigma_y, "o", ms=2.5, label="temporal std σy (DN)")
    if np.any(np.isfinite(g.mean_diff)):
        s.plot(g.signal, g.mean_diff, "s", ms=2.5, label="µ[0] − µ[1] (DN)")
    s.set(xlabel="mean − dark value (DN)", ylabel="DN", title="Stability check")
    s.legend(fontsize=6.5)
    fig2 = Figure(figsize=A4)
    _header(fig2, sheet, "Release 4.0 General: values", "general values")
    data = [[k, value_text(e), e.unit, e.note] for k, e in g.values.items()]
    text_table(fig2, (0.06, 0.9, 0.88), ["quantity", "value", "unit", "definition"], data, [1.1, 1.2, 0.8, 4.5],
               fontsize=7, max_chars=[18, 22, 12, 80])
    return [fig, fig2]


def notes_page(sheet, general=None) -> Figure:
    import textwrap

    fig = Figure(figsize=A4)
    _header(fig, sheet, "Measurement, release and notes", "notes")
    y = 0.91
    lines = [f"Release used for the analysis: {sheet.release}" +
             (" (and 4.0 General, see its pages)" if general is not None else ""),
             f"Measurement date: {sheet.meta.get('date') or 'not recorded'}",
             f"Data: {sheet.meta.get('source', '')}", f"Saturation: {sheet.photon_transfer.saturation}"]
    lines += [f"Note: {n}" for n in sheet.notes]
    if general is not None:
        lines += [f"General: {n}" for n in general.notes]
    lines += ["Not available values and limits:"]
    lines += [f"  {SYMBOLS.get(k, k)}: {e.text()} — {e.note}" for k, e in sheet.values.items()
              if not e.available or e.bound]
    for ln in lines:
        for w in textwrap.wrap(ln, 120, subsequent_indent="    ") or [""]:
            fig.text(0.06, y, w, fontsize=7.3, va="top")
            y -= 0.0145
            if y < 0.05:
                return fig
    return fig


def pages(sheet, general=None) -> list[tuple[str, Figure]]:
    out = [("EMVA summary", summary_page(sheet)), ("EMVA photon transfer", photon_transfer_page(sheet)),
           ("EMVA dark current", dark_current_page(sheet))]
    for title, fn in (("EMVA spatial variances", spatial_steps_page), ("EMVA spectrograms", spectrogram_page),
                      ("EMVA profiles", profiles_page), ("EMVA histograms", histogram_page)):
        f = fn(sheet)
        if f is not None:
            out.append((title, f))
    out += [("EMVA general", f) for f in general_pages(sheet, general)]
    out.append(("EMVA notes", notes_page(sheet, general)))
    return out


def write_datasheet(sheet, path: str | Path, general=None) -> list[str]:
    """The datasheet PDF at ``path`` (written to a temporary name, then renamed)."""
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with matplotlib.rc_context(RC):
        pg = pages(sheet, general)
        with PdfPages(tmp, metadata={"Title": f"EMVA 1288 datasheet ({sheet.release})", "Creator": "ares"}) as pdf:
            for _, fig in pg:
                pdf.savefig(fig)
    tmp.replace(path)
    return [t for t, _ in pg]
