"""The detail pages of the EMVA 1288 Release 4.0 datasheets (``ares.report.datasheet``): each
mandatory graph of Table 1 with a table of the data it was read from -- photon transfer,
characteristic curve (Fig. 5), stability (Fig. 6), linearity (Fig. 9), dark current,
spatial variances, spectrograms with their peaks, profiles and histograms, and the General
characteristic curve and input SNR. Every page carries the release it belongs to in its footer.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from ares.analysis.emva.sheet import SYMBOLS, symbol
from ares.analysis.emva.graphs import spectrum_peaks
from ares.analysis.stats.estimate import note_text
from ares.report.plots import A4, row_lines, table_lines_between, text_table

LINEAR = "EMVA 1288 Release 4.0 Linear"
GENERAL = "EMVA 1288 Release 4.0 General"


def value_text(e) -> str:
    """A value without its unit; where there is none, "cannot be measured" when the text says
    so (the General model's K, eta, electrons), else "n/a" (the reason is on the notes page)."""
    if e.available:
        return e.text(with_unit=False)
    return "cannot be measured" if "cannot be measured" in (e.note or "").lower() else "n/a"


def given(m: dict, k: str, unit: str = "") -> str:
    """A descriptor/option field as text, "not given" where nobody stated it."""
    v = m.get(k)
    return "not given" if v in (None, "") else (f"{v:g}{unit}" if isinstance(v, (int, float)) else str(v))


def _header(fig: Figure, sheet, title: str, page: str, rel: str = LINEAR) -> None:
    m = sheet.meta
    fig.text(0.05, 0.975, "EMVA 1288", fontsize=13, weight="bold", va="top")
    ident = ", ".join(f"{k}: {given(m, k)}" for k in ("vendor", "model", "serial")) + \
        f", measurement date: {given(m, 'date')}"
    fig.text(0.95, 0.975, ident, fontsize=8, ha="right", va="top")
    fig.text(0.5, 0.948, title, fontsize=11.5, weight="bold", ha="center", va="top")
    fig.text(0.05, 0.012, str(m.get("footer") or m.get("source") or ""), fontsize=6.5, color="0.4")
    fig.text(0.95, 0.012, f"{rel} · {page}", fontsize=7, ha="right", color="0.3")


def _shown(sheet, key: str) -> str:
    """A figure's text for a title, "not available" where the evaluation stopped before it."""
    e = sheet.values.get(key)
    return e.text() if e is not None else "not available"


def dark_var_text(sheet) -> str:
    """sigma_y.dark and its square, the same figure (Eq. 18 of the dark images, as Table 2)."""
    e = sheet.values.get("sigma_y_dark")
    if e is None or not e.available:
        return "σy.dark not available"
    return f"σ²y.dark = {e.value ** 2:.4g} DN² (σy.dark = {e.text()})"


def fit_range_text(sig, levels, y_sat) -> str:
    """Which steps a regression read, as steps and as a share of saturation."""
    lv = np.asarray(levels, int)
    if not lv.size:
        return "no steps"
    lo, hi = float(sig[lv].min()), float(sig[lv].max())
    pct = f", {100 * lo / y_sat:.0f} - {100 * hi / y_sat:.0f} % of µy.sat" if y_sat and y_sat > 0 else ""
    return f"steps {lv.min()} - {lv.max()}{pct}"


def _y_sat(sheet) -> float:
    e = sheet.values.get("mu_y_sat")
    return e.value if e is not None and e.available else math.nan


def _ptc_axes(ax, sheet, large: bool = False) -> None:
    c = sheet.curves
    v, sig = c["var"], c["signal"]
    fit = np.asarray(c["fit_levels"], int)
    K = sheet.values["K"]
    ax.plot(sig, v, "o", ms=3 if large else 2.5, color="C0", label="mono data")
    if fit.size and K.available:
        ax.plot(sig[fit], v[fit], "o", ms=3 if large else 2.5, color="C3", label="fitted steps")
        xs = np.array([0.0, float(sig[fit].max())])
        off = float(np.mean(v[fit] - K.value * sig[fit]))
        ax.plot(xs, off + K.value * xs, "-", color="C1",
                label=f"mono fit ({fit_range_text(sig, fit, _y_sat(sheet))})")
    if c.get("index_sat") is not None:
        ax.axvline(sig[c["index_sat"]], ls="--", color="0.4", lw=0.8, label="saturation")
    ax.text(0.03, 0.95, f"{dark_var_text(sheet)}\nK = {K.text()}", transform=ax.transAxes, fontsize=7, va="top")
    ax.set(xlabel="mean − dark value (DN)", ylabel="variance − dark variance (DN²)", title="Photon transfer")
    # under the text, top left: the curve rises from the bottom left, and the steps past
    # saturation fall to the bottom right, where the legend hid them
    ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(0.0, 0.86))


def characteristic_axes(ax, sheet) -> None:
    """Linear Fig. 5: µy − µy.dark vs µp, the regression line of R (Eq. 49, through 0) and the
    steps it read."""
    c = sheet.curves
    x, sig = c["photons"], c["signal"]
    fit = np.asarray(c["fit_levels"], int)
    ax.plot(x, sig, "o", ms=2.5, color="C0", label="mono data")
    R = sheet.values.get("R")
    if fit.size:
        ax.plot(x[fit], sig[fit], "o", ms=2.5, color="C3", label=f"R fit: {fit_range_text(sig, fit, _y_sat(sheet))}")
        if R is not None and R.available:
            xs = np.array([0.0, float(x.max())])
            ax.plot(xs, R.value * xs, "-", lw=0.8, color="C1", label=f"R = {R.text()}")
    ax.set(xlabel="irradiation (photons/pixel)", ylabel="mean − dark (DN)", title="Characteristic curve (Fig. 5)")
    ax.set_ylim(0, max(float(np.nanmax(sig)) * 1.1, 1))
    ax.legend(fontsize=6)


def stability_axes(ax, signal, sigma_y, mean_diff) -> None:
    """Fig. 6: sigma_y (Eq. 18) and µ[0] − µ[1] of each pair vs µy − µy.dark."""
    ax.plot(signal, sigma_y, "o", ms=2.5, color="C0", label="mono std σy")
    md = np.asarray(mean_diff, float) if mean_diff is not None else np.full(np.size(signal), np.nan)
    if np.any(np.isfinite(md)):
        ax.plot(signal, md, "s", ms=2.5, color="C1", label="mono diff µ[0] − µ[1]")
    else:
        ax.text(0.5, 0.5, "µ[0] − µ[1] not recorded", transform=ax.transAxes, ha="center", fontsize=7)
    ax.axhline(0, color="0.6", lw=0.6)
    ax.set(xlabel="mean − dark value (DN)", ylabel="difference/std (DN)", title="Stability check (Fig. 6)")
    ax.legend(fontsize=6)


def linearity_page(sheet, rel: str = LINEAR) -> Figure:
    """Linear Fig. 9: a) µy − µy.dark vs µp with the regression line of Eqs. 59 - 60 over all
    values, the steps it read marked; b) the deviations of Eq. 62."""
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Linearity (Section 6.9)", "linearity", rel)
    c = sheet.curves
    x, sig, dev = c["photons"], c["signal"], c["deviation_pct"]
    le = np.asarray(c["le_levels"], int)
    a = fig.add_axes([0.1, 0.55, 0.8, 0.34])
    a.plot(x, sig, "o", ms=2.5, color="0.6", label="mono data")
    if le.size >= 2 and np.all(np.isfinite(dev[le])):
        fit = sig[le] / (1 + dev[le] / 100)  # the regression line at the steps it read (Eq. 62)
        a1, a0 = np.polyfit(x[le], fit, 1)
        a.plot(x[le], sig[le], "o", ms=3, color="C0", label=f"LE fit: {fit_range_text(sig, le, _y_sat(sheet))}")
        xs = np.array([0.0, float(x.max())])
        a.plot(xs, a0 + a1 * xs, "-", lw=0.8, color="C1", label=f"regression (Eqs. 59 - 60): {a0:.4g} + {a1:.4g} µp")
    a.set(xlabel="irradiation (photons/pixel)", ylabel="mean − dark (DN)", title="a  Linearity: data and regression")
    a.legend(fontsize=6.5)
    b = fig.add_axes([0.1, 0.1, 0.8, 0.34])
    okd = np.isfinite(dev)
    b.plot(x[okd], dev[okd], "o-", ms=2.5, lw=0.6, color="C0", label="mono data")
    b.axhline(0, color="0.5", lw=0.6)
    b.set(xlabel="irradiation (photons/pixel)", ylabel="deviation (%)",
          title=f"b  Linearity error: deviation from the regression (Eq. 62), LE = {_shown(sheet, 'LE')}")
    return fig


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


def _data_table(fig, top, header, data, widths, title=""):
    return text_table(fig, (0.08, top, 0.84), header, data, widths, fontsize=6.8, title=title)


def photon_transfer_page(sheet, rel: str = LINEAR) -> Figure:
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Sensitivity and noise (Section 6.6): Figs. 5 - 7", "photon transfer", rel)
    c = sheet.curves
    a = fig.add_axes([0.1, 0.68, 0.8, 0.23])
    _ptc_axes(a, sheet, large=True)
    characteristic_axes(fig.add_axes([0.1, 0.41, 0.36, 0.2]), sheet)
    stability_axes(fig.add_axes([0.58, 0.41, 0.34, 0.2]), c["signal"], np.sqrt(np.maximum(c["var_bright"], 0)),
                   c.get("mean_diff"))
    x, sig, dev = c["photons"], c["signal"], c["deviation_pct"]
    n = len(x)
    pick = np.unique(np.linspace(0, n - 1, min(n, 18)).round().astype(int))
    fitset = set(np.asarray(c["fit_levels"], int).tolist())
    data = [[str(i), f"{x[i]:.4g}", f"{sig[i]:.4g}", f"{c['var'][i]:.4g}", f"{c['snr'][i]:.3g}",
             "fit" if i in fitset else "", "" if not np.isfinite(dev[i]) else f"{dev[i]:+.2f}"]
            for i in pick]
    _data_table(fig, 0.335, ["step", "µp (photons)", "µy − µy.dark (DN)", "σ²y − σ²y.dark (DN²)", "SNR", "K fit",
                             "δy (%)"], data, [0.6, 1.2, 1.4, 1.5, 0.9, 0.6, 0.8],
                title=f"Extracted data ({len(pick)} of {n} steps; all in the CSV)")
    return fig


def dark_current_page(sheet, rel: str = LINEAR) -> Figure:
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Dark current (Section 7)", "dark current", rel)
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


def spatial_steps_page(sheet, rel: str = LINEAR) -> Figure | None:
    c = sheet.curves
    if "step_s2_bright_total" not in c:
        return None
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Spatial variances at every exposure step (Sections 4.2, 4.3)", "spatial variances", rel)
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


def spectrogram_page(sheet, rel: str = LINEAR) -> Figure | None:
    c = sheet.curves
    if "spectrogram_dsnu_h" not in c:
        return None
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Horizontal and vertical spectrograms (Section 8.6)", "spectrograms", rel)
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
    rows = peak_rows(c, specs)
    _data_table(fig, 0.165, ["spectrogram", "cycles/pixel", "bins", "amplitude (Eq. 72)", "noise alone", "P/noise",
                             "false alarm", "unit"], rows or [["no peak above the noise", "", "", "", "", "", "", ""]],
                [1.5, 0.9, 0.8, 1.2, 0.9, 0.8, 0.9, 0.4],
                title="Peaks above the noise (whole peak; false alarm: chance of noise this high anywhere)")
    return fig


def peak_rows(c: dict, specs) -> list[list[str]]:
    """The spectrogram peak table: each peak's whole amplitude and its significance."""
    rows = []
    for key, title, _, unit in specs:
        if key not in c:
            continue
        for pk in spectrum_peaks(c[key], max_peaks=2):
            rows.append([title, f"{pk.freq:.4f}", f"{pk.bins[0]} - {pk.bins[1]}", f"{pk.amplitude:.3g}",
                         f"{pk.noise_amplitude:.2g}", f"{pk.ratio:.3g}", f"{pk.p_false:.1g}", unit])
    return rows


def profiles_page(sheet, rel: str = LINEAR) -> Figure | None:
    c = sheet.curves
    if "profile_dsnu_h" not in c:
        return None
    from ares.analysis.emva.graphs import profile_range

    fig = Figure(figsize=A4)
    _header(fig, sheet, "Horizontal and vertical profiles, not high-pass filtered (Section 8.7)", "profiles", rel)
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


def histogram_page(sheet, rel: str = LINEAR) -> Figure | None:
    c = sheet.curves
    if "hist_dsnu" not in c:
        return None
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Defect pixel characterization (Section 8.8)", "histograms", rel)
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


def general_curve_axes(ax, g) -> None:
    """General Fig. 5: the characteristic curve and its B-spline regression (Eqs. 44 - 47)."""
    ax.plot(g.photons, g.signal, "o", ms=2.5, label="mono data")
    xs = np.linspace(0, g.curve.x_max, 300)
    ax.plot(xs, g.curve(xs), "-", lw=0.9, label=f"cubic B-spline, {g.curve.P} intervals, 0 - {g.curve.x_max:.4g}")
    ax.set(xlabel="irradiation (photons/pixel)", ylabel="mean − dark value (DN)", title="Characteristic curve")
    ax.legend(fontsize=6.5)


def general_snr_axes(ax, g) -> None:
    x = g.photons
    below = np.arange(x.size) <= (g.index_sat if g.index_sat is not None else x.size)  # clipped steps not drawn
    ok = below & np.isfinite(g.snr_p) & (g.snr_p > 0) & (x > 0)
    ax.loglog(x[ok], g.snr_p[ok], "o", ms=2.5, label="input SNR_p (Eq. 10)")
    oky = below & np.isfinite(g.snr_y) & (g.snr_y > 0) & (x > 0)
    ax.loglog(x[oky], g.snr_y[oky], "^", ms=2.5, label="output SNR_y (Eq. 7)")
    ax.loglog(x[x > 0], np.sqrt(x[x > 0]), ":", color="0.3", label="ideal sensor (Eq. 15)")
    ax.axhline(1, color="0.6", lw=0.7)
    ax.set(xlabel="irradiation (photons/pixel)", ylabel="SNR", title="Input SNR")
    ax.legend(fontsize=6.5)


def general_pages(sheet, general, rel: str = GENERAL) -> list[Figure]:
    if general is None or general.curve is None:
        return []
    g = general
    fig = Figure(figsize=A4)
    _header(fig, sheet, "Characteristic curve, input SNR and stability (General 6.6 - 6.8)", "general graphs", rel)
    general_curve_axes(fig.add_axes([0.1, 0.68, 0.8, 0.22]), g)
    general_snr_axes(fig.add_axes([0.1, 0.38, 0.8, 0.22]), g)
    stability_axes(fig.add_axes([0.1, 0.08, 0.8, 0.22]), g.signal, g.sigma_y, g.mean_diff)
    return [fig, values_page(sheet, g.values, "Release 4.0 General: every value with its definition",
                             "general values", rel, general=True)]


def values_page(sheet, values: dict, title: str, page: str, rel: str = LINEAR, general: bool = False) -> Figure:
    """Every value of a release with its definition: the figures the summary sheet leaves
    out (R, µp.min, the stacks' temporal noise ...) are on the datasheet too, as in its CSV;
    each under its symbol (``general``: the General table's), as on every other surface."""
    fig = Figure(figsize=A4)
    _header(fig, sheet, title, page, rel)
    # an exact value's verdict leads its definition, as in the CSV (the value column would cut it)
    data = [[symbol(k, general), e.text(with_unit=False, with_exact=False) if e.available else value_text(e), e.unit,
             note_text(e.to_dict())] for k, e in values.items()]
    size, chars = 7 if len(data) <= 45 else 6, [18, 24, 12, 72]
    room = table_lines_between(0.9, 0.05, size, False)  # lines down to the footer
    text_table(fig, (0.06, 0.9, 0.88), ["quantity", "value", "unit", "definition"], data, [1.1, 1.6, 0.8, 4.1],
               fontsize=size, max_chars=chars, wrap=sum(row_lines(r, chars) for r in data) <= room)  # whole if it fits
    return fig
