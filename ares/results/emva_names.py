"""EMVA 1288 results under the names of the certification convention: the tree
``ares emva --xml`` writes (``ares.report.emva_xml``) and ``ares emva-compare`` reads.

The EMVA's reference implementation (PyPI ``emva1288``) writes its results as an XML tree
``results / SECTION / NAME / (value | data / ARRAY)``: every named result under its exact
name, a scalar as ``value`` and an array result (histograms) as named whitespace-separated
arrays under ``data``. This module maps an ``EmvaAnalysis`` onto that tree -- pure values,
no file I/O:

* ``release31``: every name of the convention for Release 3.1 (sections ``info``,
  ``sensitivity``, ``linearity``, ``dark_current``, ``spatial``, ``defect_pixel``), with
  ARES's Release 3.x values (``EmvaAnalysis.emva`` and ``.release31``) and the spatial
  variances of the averaged stacks; where ARES reads the text differently from the reference
  implementation the value is ARES's and ``docs/emva1288_releases.md`` names the clause;
* ``release40``: the same structure for Release 4.0 Linear or General, with the 4.0 names
  (the keys of Table 2, ``ares.analysis.emva.sheet.TABLE2`` / ``general_table.GENERAL_TABLE2``)
  and the graph data (spectrograms, profiles, histograms) under ``graphs``.

An entry is ``{"value": float | None, "se", "bound", "unit", "symbol", "short", "note"}`` or,
for an array result, ``{"data": {name: ndarray}, ...}``; ``None`` is "not available" (its
``note`` says why). docs/emva_xml.md lists every name.
"""

from __future__ import annotations

import math

import numpy as np

from ares.analysis.stats.estimate import Estimate

# Release 3.1 names of the certification convention: (section, name, unit, symbol, short description)
NAMES31 = (
    ("info", "index_start", "", "", "first level index of the arrays"),
    ("sensitivity", "index_u_ysat", "", "", "level of saturation (maximum temporal variance)"),
    ("sensitivity", "index_sensitivity_max", "", "", "last level of the fits, <= 70 % of saturation"),
    ("sensitivity", "index_sensitivity_min", "", "", "first level of the fits"),
    ("sensitivity", "R", "DN/p", "R", "responsivity"),
    ("sensitivity", "K", "DN/e-", "K", "overall system gain"),
    ("sensitivity", "inverse_K", "e-/DN", "1/K", "inverse overall system gain"),
    ("sensitivity", "QE", "%", "eta", "quantum efficiency"),
    ("sensitivity", "sigma_y_dark", "DN", "sigma_y.dark", "temporal dark noise"),
    ("sensitivity", "sigma_d", "e-", "sigma_d", "temporal dark noise in electrons"),
    ("sensitivity", "u_p_min", "p", "mu_p.min", "absolute sensitivity threshold"),
    ("sensitivity", "u_p_min_area", "p/um^2", "mu_p.min.area", "absolute sensitivity threshold per area"),
    ("sensitivity", "u_e_min", "e-", "mu_e.min", "absolute sensitivity threshold in electrons"),
    ("sensitivity", "u_e_min_area", "e-/um^2", "mu_e.min.area", "sensitivity threshold in electrons per area"),
    ("sensitivity", "u_p_sat", "p", "mu_p.sat", "saturation capacity in photons"),
    ("sensitivity", "u_p_sat_area", "p/um^2", "mu_p.sat.area", "saturation capacity in photons per area"),
    ("sensitivity", "u_e_sat", "e-", "mu_e.sat", "saturation capacity"),
    ("sensitivity", "u_e_sat_area", "e-/um^2", "mu_e.sat.area", "saturation capacity per area"),
    ("sensitivity", "SNR_max", "", "SNR_max", "maximum signal-to-noise ratio"),
    ("sensitivity", "SNR_max_dB", "dB", "SNR_max", "maximum signal-to-noise ratio in dB"),
    ("sensitivity", "SNR_max_bit", "bit", "SNR_max", "maximum signal-to-noise ratio in bits"),
    ("sensitivity", "inverse_SNR_max", "%", "1/SNR_max", "inverse maximum signal-to-noise ratio"),
    ("sensitivity", "DR", "", "DR", "dynamic range"),
    ("sensitivity", "DR_dB", "dB", "DR", "dynamic range in dB"),
    ("linearity", "index_linearity_min", "", "", "first level of the linearity fit (>= 5 % of saturation)"),
    ("linearity", "index_linearity_max", "", "", "last level of the linearity fit (<= 95 % of saturation)"),
    ("linearity", "LE_min", "%", "LE_min", "minimum linearity error"),
    ("linearity", "LE_max", "%", "LE_max", "maximum linearity error"),
    ("dark_current", "u_I_mean_DN", "DN/s", "mu_I.mean", "dark current from the mean, in DN"),
    ("dark_current", "u_I_mean", "e-/s", "mu_I.mean", "dark current from the mean"),
    ("dark_current", "u_I_var_DN", "DN/s", "mu_I.var", "dark current from the variance, times K"),
    ("dark_current", "u_I_var", "e-/s", "mu_I.var", "dark current from the variance"),
    ("spatial", "sigma_2_y_stack", "DN^2", "sigma^2_y.stack", "temporal variance of the bright stack"),
    ("spatial", "sigma_2_y_stack_dark", "DN^2", "sigma^2_y.stack.dark", "temporal variance of the dark stack"),
    ("spatial", "s_2_y_measured", "DN^2", "s^2_y.measured", "spatial variance of the averaged bright image"),
    ("spatial", "s_2_y_measured_dark", "DN^2", "s^2_y.measured.dark", "spatial variance of the averaged dark image"),
    ("spatial", "s_2_y", "DN^2", "s^2_y", "spatial variance, temporal part removed"),
    ("spatial", "s_2_y_dark", "DN^2", "s^2_y.dark", "dark spatial variance, temporal part removed"),
    ("spatial", "s_2_y_cav", "DN^2", "s^2_y.cav", "variance of the column averages"),
    ("spatial", "s_2_y_cav_dark", "DN^2", "s^2_y.cav.dark", "variance of the dark column averages"),
    ("spatial", "s_2_y_rav", "DN^2", "s^2_y.rav", "variance of the row averages"),
    ("spatial", "s_2_y_rav_dark", "DN^2", "s^2_y.rav.dark", "variance of the dark row averages"),
    ("spatial", "s_2_y_col", "DN^2", "s^2_y.col", "column spatial variance"),
    ("spatial", "s_2_y_col_dark", "DN^2", "s^2_y.col.dark", "dark column spatial variance"),
    ("spatial", "s_2_y_row", "DN^2", "s^2_y.row", "row spatial variance"),
    ("spatial", "s_2_y_row_dark", "DN^2", "s^2_y.row.dark", "dark row spatial variance"),
    ("spatial", "s_2_y_pixel", "DN^2", "s^2_y.pixel", "pixel spatial variance"),
    ("spatial", "s_2_y_pixel_dark", "DN^2", "s^2_y.pixel.dark", "dark pixel spatial variance"),
    ("spatial", "DSNU1288", "e-", "DSNU1288", "dark signal nonuniformity"),
    ("spatial", "DSNU1288_DN", "DN", "DSNU1288", "dark signal nonuniformity in DN"),
    ("spatial", "DSNU1288_row", "e-", "DSNU1288.row", "row dark signal nonuniformity"),
    ("spatial", "DSNU1288_col", "e-", "DSNU1288.col", "column dark signal nonuniformity"),
    ("spatial", "DSNU1288_pixel", "e-", "DSNU1288.pixel", "pixel dark signal nonuniformity"),
    ("spatial", "PRNU1288", "%", "PRNU1288", "photo response nonuniformity"),
    ("spatial", "PRNU1288_row", "%", "PRNU1288.row", "row photo response nonuniformity"),
    ("spatial", "PRNU1288_col", "%", "PRNU1288.col", "column photo response nonuniformity"),
    ("spatial", "PRNU1288_pixel", "%", "PRNU1288.pixel", "pixel photo response nonuniformity"),
    ("defect_pixel", "histogram_DSNU", "DN", "", "logarithmic histogram of the high-passed averaged dark image"),
    ("defect_pixel", "histogram_DSNU_accumulated", "DN", "", "accumulated histogram of |dark - mean|"),
    ("defect_pixel", "histogram_PRNU", "%", "", "logarithmic histogram of the high-passed averaged bright - dark "
                                                "image"),
    ("defect_pixel", "histogram_PRNU_accumulated", "%", "", "accumulated histogram of |bright - dark - mean|"),
)
SECTIONS31 = ("info", "sensitivity", "linearity", "dark_current", "spatial", "defect_pixel")


def entry(e: Estimate | float | int | None, unit: str = "", symbol: str = "", short: str = "", note: str = "") -> dict:
    """One scalar entry: an Estimate (its value, SE, bound and note) or a plain number."""
    if isinstance(e, Estimate):
        return {"value": float(e.value) if e.available else None,
                "se": float(e.se) if e.available and math.isfinite(e.se) else None,
                "bound": e.bound, "unit": unit or e.unit, "symbol": symbol, "short": short, "note": note or e.note}
    v = None if e is None or not math.isfinite(float(e)) else float(e)
    return {"value": v, "se": None, "bound": "", "unit": unit, "symbol": symbol, "short": short, "note": note}


def array_entry(data: dict, unit: str = "", symbol: str = "", short: str = "", note: str = "") -> dict:
    return {"data": {k: np.asarray(a, float).ravel() for k, a in data.items()}, "unit": unit, "symbol": symbol,
            "short": short, "note": note}


def _scale(e: Estimate, f: float, unit: str, note: str) -> Estimate:
    if not e.available:
        return Estimate.na(e.note, unit)
    return Estimate(e.value * f, abs(e.se * f) if math.isfinite(e.se) else math.nan, unit, note, e.bound)


def _stack_variances(st, suffix: str) -> dict[str, float]:
    """The Release 3.x spatial variances of one averaged stack: s^2 of the averaged image with
    1/(MN - 1) (ARES's Release 3.0 DSNU1288/PRNU1288, ``release3``), less the temporal part
    sigma^2_stack / L; the variances of the column and row averages (4.0 Linear Eqs. 37, 38);
    and the column, row and pixel parts solved from them (4.0 Linear Eqs. 39 - 41; Release 3.1
    has no split, 4.0 Linear Appendix E.2 item 3)."""
    img, L, tv = st.mean_image, st.L, st.temporal_var
    M, N = img.shape
    mu = float(img.mean())
    measured = float(np.var(img, ddof=1))
    s2 = measured - tv / L
    cav = float(np.mean((img.mean(axis=0) - mu) ** 2)) - tv / (L * M)
    rav = float(np.mean((img.mean(axis=1) - mu) ** 2)) - tv / (L * N)
    d = M * N - M - N
    col = (M * N - M) / d * cav - N / d * (s2 - rav)
    row = (M * N - N) / d * rav - M / d * (s2 - cav)
    pix = M * N / d * (s2 - cav - rav)
    return {"sigma_2_y_stack" + suffix: tv, "s_2_y_measured" + suffix: measured, "s_2_y" + suffix: s2,
            "s_2_y_cav" + suffix: cav, "s_2_y_rav" + suffix: rav, "s_2_y_col" + suffix: col,
            "s_2_y_row" + suffix: row, "s_2_y_pixel" + suffix: pix, "mean" + suffix: mu}


def _linearity_window(td, isat: int) -> tuple[float, float]:
    """The first level at or above 5 % and the last at or below 95 % of the saturation signal
    (the window of LE_min/LE_max, ``release3._linearity``)."""
    Y = td.u_y - td.u_ydark
    if not Y[isat] > 0:
        return math.nan, math.nan
    above, below = np.nonzero(Y >= 0.05 * Y[isat])[0], np.nonzero(Y <= 0.95 * Y[isat])[0]
    return (float(above[0]) if above.size else math.nan), (float(below[-1]) if below.size else math.nan)


def _histograms31(sd, sb) -> dict:
    """The defect-pixel histograms of Release 3.1: the averaged images high-passed by the 5 x 5
    box (4.0 Linear Appendix C.5, Eq. 84; 3.1 Appendix C.3 item 10: before every nonuniformity
    evaluation but the spectrograms), binned by 4.0 Linear Eqs. 73 - 81 (``graphs``); PRNU
    relative to the mean signal, in %."""
    from ares.analysis.emva import graphs

    out = {}
    try:
        dark = sd.highpassed("3.1")
    except ValueError as exc:
        return {k: str(exc) for k in ("histogram_DSNU", "histogram_DSNU_accumulated", "histogram_PRNU",
                                      "histogram_PRNU_accumulated")}
    h, a = graphs.log_histogram(dark, sd.L), graphs.accumulated_histogram(dark, sd.L)
    out["histogram_DSNU"] = {"bins": h.centers, "values": h.counts, "model": h.model}
    out["histogram_DSNU_accumulated"] = {"bins": a.deviation, "values": a.percent}
    if sb is None:
        out["histogram_PRNU"] = out["histogram_PRNU_accumulated"] = "no bright stack"
        return out
    img = sb.highpassed("3.1") - dark
    sig = float(sb.mean_image.mean() - sd.mean_image.mean())
    if not sig > 0:
        out["histogram_PRNU"] = out["histogram_PRNU_accumulated"] = "no signal in the bright stack above dark"
        return out
    h, a = graphs.log_histogram(img, sb.L), graphs.accumulated_histogram(img, sb.L)
    rel = 100.0 / sig
    out["histogram_PRNU"] = {"bins": h.centers * rel, "values": h.counts, "model": h.model}
    out["histogram_PRNU_accumulated"] = {"bins": a.deviation * rel, "values": a.percent}
    return out


def release31(an, pixel_area_um2: float | None = None, release: str = "3.1") -> dict:
    """Every name of the Release 3.1 certification convention, ``{section: {name: entry}}``
    (``release="3.0"``: the same names with DSNU1288/PRNU1288 of Release 3.0, unfiltered)."""
    r = an.emva
    v, x, td = r.values, r.extra, r.temporal
    r31 = (an.release31 or {}) if release == "3.1" else {}
    K = v["K"]
    na = Estimate.na
    val: dict[str, Estimate | float | None] = {"index_start": 0, "index_u_ysat": r.index_u_ysat,
                                               "index_sensitivity_max": r.index_sensitivity_max,
                                               "index_sensitivity_min": 0}
    for k in ("K", "QE", "sigma_y_dark", "u_e_sat", "SNR_max", "DR", "u_I_mean", "LE_min", "LE_max"):
        val[k] = v[k]
    for k in ("R", "sigma_d", "u_p_min", "u_e_min", "u_p_sat", "SNR_max_dB", "DR_dB"):
        val[k] = x.get(k, na("not computed for this data set"))
    val["u_I_var"] = x.get("u_I_var", na(v["u_I_mean"].note or "needs more than two exposure times", "e-/s"))
    val["inverse_K"] = (Estimate(1 / K.value, K.se / K.value**2, "e-/DN", "1 / K") if K.available
                        else na(K.note, "e-/DN"))
    snr = v["SNR_max"]
    val["SNR_max_bit"] = (Estimate(math.log2(snr.value), snr.se / (snr.value * math.log(2)), "bit", "log2 SNR_max")
                          if snr.available else na(snr.note, "bit"))
    val["inverse_SNR_max"] = (Estimate(100 / snr.value, 100 * snr.se / snr.value**2, "%", "100 / SNR_max")
                              if snr.available else na(snr.note, "%"))
    for k in ("u_p_min", "u_e_min", "u_p_sat", "u_e_sat"):
        val[k + "_area"] = (_scale(val[k], 1 / pixel_area_um2, "", f"/ pixel area ({pixel_area_um2:g} um^2)")
                            if pixel_area_um2 else na("pixel size not given (--pixel-size-um)"))
    for k in ("u_I_mean", "u_I_var"):
        e = val[k]
        val[k + "_DN"] = (_scale(e, K.value, "DN/s", f"{k} x K") if K.available else na(K.note, "DN/s"))
    lo, hi = _linearity_window(td, r.index_u_ysat)
    val["index_linearity_min"], val["index_linearity_max"] = lo, hi
    sd, sb = (an.inp.stack_dark, an.inp.stack_bright) if an.inp is not None else (None, None)
    hists: dict = {}
    if sd is None:
        why = "no dark stack (averaged images, Section 8) in the data set"
        for _, name, *_ in NAMES31:
            if name.startswith(("sigma_2", "s_2", "DSNU", "PRNU")):
                val[name] = na(why)
        hists = {k: why for k in ("histogram_DSNU", "histogram_DSNU_accumulated", "histogram_PRNU",
                                  "histogram_PRNU_accumulated")}
    else:
        sv = _stack_variances(sd, "_dark")
        sv.update(_stack_variances(sb, "") if sb is not None else {})
        for _, name, *_ in NAMES31:
            if name.startswith(("sigma_2", "s_2")):
                val[name] = sv.get(name, na("no bright stack"))
        val["DSNU1288"] = r31.get("DSNU1288", v["DSNU1288"])
        ds = val["DSNU1288"]
        val["DSNU1288_DN"] = (x["DSNU1288_DN"] if release == "3.0" and "DSNU1288_DN" in x else  # (its own SE)
                              _scale(ds, K.value, "DN", "DSNU1288 x K") if K.available else na(K.note))
        sig = sv["mean"] - sv["mean_dark"] if sb is not None else math.nan
        for part in ("row", "col", "pixel"):
            s2d = sv[f"s_2_y_{part}_dark"]
            val[f"DSNU1288_{part}"] = (na(K.note) if not K.available else
                                       math.sqrt(s2d) / K.value if s2d >= 0 else
                                       na(f"the dark {part} variance {s2d:.4g} DN^2 is negative"))
            if sb is None:
                val[f"PRNU1288_{part}"] = na("no bright stack")
                continue
            d2 = sv[f"s_2_y_{part}"] - s2d
            val[f"PRNU1288_{part}"] = (100 * math.sqrt(d2) / sig if d2 >= 0 and sig > 0 else
                                       na(f"no {part} signal variance above dark ({d2:.4g} DN^2)"))
        val["PRNU1288"] = r31.get("PRNU1288", v["PRNU1288"])
        hists = _histograms31(sd, sb)
    out: dict = {s: {} for s in SECTIONS31}
    for section, name, unit, symbol, short in NAMES31:
        if name in hists:
            h = hists[name]
            out[section][name] = (array_entry(h, unit, symbol, short) if isinstance(h, dict) else
                                  {"data": None, "unit": unit, "symbol": symbol, "short": short, "note": h})
        else:
            e = val[name]
            out[section][name] = entry(e, unit, symbol, short)
    return out


GRAPHS40 = ("spectrogram_dsnu_h", "spectrogram_dsnu_v", "spectrogram_prnu_h", "spectrogram_prnu_v",
            "profile_dsnu_h", "profile_dsnu_v", "profile_prnu_h", "profile_prnu_v",
            "hist_dsnu", "acc_dsnu", "hist_prnu", "acc_prnu")


def _section40(key: str) -> str:
    """The section of a Release 4.0 key (Table 2 and the sheets' extra figures)."""
    base = key.split(".")[0]
    if base == "LE":
        return "linearity"
    if base.startswith("mu_I"):
        return "dark_current"
    if base.startswith(("DSNU", "PRNU", "sigma_y_stack")):
        return "spatial"
    return "sensitivity"


def _graph_data(g) -> dict | None:
    """A graph of the sheet as named arrays (None for what is not an array graph)."""
    from ares.analysis.emva import graphs

    if isinstance(g, graphs.Spectrogram):
        return {"freq": g.freq, "sqrt_power": g.sqrt_power}
    if isinstance(g, graphs.Histogram):
        return {"bins": g.centers, "values": g.counts, "model": g.model}
    if isinstance(g, graphs.Accumulated):
        return {"bins": g.deviation, "values": g.percent, "count": g.count}
    if isinstance(g, dict) and g and all(isinstance(a, np.ndarray) for a in g.values()):
        return dict(g)
    return None


def release40(an, model: str = "linear") -> dict:
    """The Release 4.0 Linear (``model="linear"``) or General tree, ``{section: {name: entry}}``:
    every Table 2 key (and the sheets' extra figures) with its SE or verdict, and for Linear the
    graph data of Section 10.2 under ``graphs``."""
    from ares.analysis.emva.general_table import GENERAL_TABLE2
    from ares.analysis.emva.sheet import SYMBOLS

    if model == "linear":
        values, symbols, curves = an.sheet.values, SYMBOLS, an.sheet.curves
    else:
        values, symbols, curves = an.general.values, {k: s for k, s, _ in GENERAL_TABLE2}, {}
    out: dict = {"sensitivity": {}, "linearity": {}, "dark_current": {}, "spatial": {}}
    for k, e in values.items():
        name = k.replace(".", "__")  # an ARES option's value beside the text's (``key.option``)
        out[_section40(k)][name] = entry(e, e.unit, symbols.get(k.split(".")[0], k), "")
    g = {}
    for k in GRAPHS40:
        d = _graph_data(curves.get(k)) if k in curves else None
        if d is not None:
            g[k] = array_entry(d, "", "", k.replace("_", " "))
    if g:
        out["graphs"] = g
    return out
