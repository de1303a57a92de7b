"""Report pages of the low-light analyses: dark current against temperature per pixel (the frame's
Arrhenius plot, the activation-energy map and histogram with the regimes, ln A against E_a with the
Meyer-Neldel line) and random telegraph noise (amplitude and dwell-time histograms, the figures and
the frames a given amplitude needs). The maps are computed again from the run directory
(``ares.results.lowlight``); nothing is re-measured."""

from __future__ import annotations

import math

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.report.page_tables import _table, analysis_rows
from ares.report.plots import new_page

K_B_EV = 8.617333262e-5


def dark_temperature_page(run, a: dict):
    from ares.analysis.lowlight.arrhenius import REGIMES
    from ares.results.lowlight import run_dark_temperature
    from ares.rundir.record import load_run

    fig = new_page("Dark current against temperature, per pixel",
                   "Arrhenius law I = A exp(-E_a / kT) fitted per pixel and for the frame")
    out, maps = run_dark_temperature(load_run(run.dir), a.get("ref_c", 0.0))
    fr, unit = a["frame"], a["unit"]
    T = np.asarray(a["temperatures_c"], float)
    r = np.asarray(fr["rates"], float)
    ax = fig.add_axes([0.09, 0.66, 0.36, 0.25])
    ok = r > 0
    ax.semilogy(1000 / (T[ok] + 273.15), r[ok], "o", color="C0", label="frame")
    ea, la = Estimate.from_dict(fr["activation_ev"]), Estimate.from_dict(fr["ln_prefactor"])
    if ea.available and la.available:
        xs = np.linspace((1000 / (T + 273.15)).min(), (1000 / (T + 273.15)).max(), 20)
        ax.semilogy(xs, np.exp(la.value - ea.value / (K_B_EV * 1000 / xs)), "-", color="C3", lw=0.8,
                    label=f"E_a {ea.text()}")
    ax.set_xlabel("1000 / T (1/K)")
    ax.set_ylabel(f"dark current ({unit})")
    ax.set_title("frame", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    if maps:
        m = maps["activation_ev"]
        good = m[np.isfinite(m)]
        ax2 = fig.add_axes([0.55, 0.66, 0.38, 0.25])
        lo, hi = (np.percentile(good, [1, 99]) if good.size else (0, 1))
        im = ax2.imshow(m, cmap="viridis", vmin=lo, vmax=hi, interpolation="nearest")
        fig.colorbar(im, ax=ax2, label="E_a (eV)")
        ax2.set_title("activation-energy map", fontsize=9)
        ax3 = fig.add_axes([0.09, 0.36, 0.36, 0.23])
        if good.size:
            ax3.hist(good, bins=80, color="C0", log=True)
            for _name, edge, _hi in REGIMES[1:]:
                ax3.axvline(edge, color="0.4", lw=0.7, ls="--")
        ax3.set_xlabel("E_a (eV)")
        ax3.set_ylabel("pixels")
        ax3.set_title("E_a histogram (regime bounds dashed)", fontsize=9)
        ax4 = fig.add_axes([0.55, 0.36, 0.38, 0.23])
        e, lnA = maps["activation_ev"].ravel(), maps["ln_prefactor"].ravel()
        sel = np.flatnonzero(np.isfinite(e) & np.isfinite(lnA))
        if sel.size > 5000:
            sel = np.random.default_rng(0).choice(sel, 5000, replace=False)
        ax4.plot(e[sel], lnA[sel], ".", ms=1.5, color="C0", alpha=0.5)
        mn = Estimate.from_dict(a["pixels"].get("meyer_neldel_ev", {"value": None}))
        if mn.available and sel.size:
            xs = np.linspace(np.percentile(e[sel], 1), np.percentile(e[sel], 99), 10)
            x0, y0 = float(np.median(e[sel])), float(np.median(lnA[sel]))
            ax4.plot(xs, y0 + (xs - x0) / mn.value, "-", color="C3", lw=0.9, label=f"E_MN {mn.text()}")
            ax4.legend(fontsize=7)
        ax4.set_xlabel("E_a (eV)")
        ax4.set_ylabel(f"ln A (ln {unit})")
        ax4.set_title("Meyer-Neldel: ln A against E_a", fontsize=9)
        for a_ in (ax3, ax4):
            a_.grid(alpha=0.3)
    rows = analysis_rows({k: v for k, v in fr.items() if isinstance(v, dict)}, "frame ")
    rows += analysis_rows({k: v for k, v in a["pixels"].items() if isinstance(v, dict) and "value" in v}, "pixels ")
    px = a["pixels"]
    if "regimes" in px:
        rows.append(["pixels per regime", ", ".join(f"{k} {v}" for k, v in px["regimes"].items()), ""])
        rows.append(["hot by E_a", str(px.get("hot_by_activation")), "below the bulk by > 5 robust SDs and 5 SEs"])
    _table(fig, 0.30, rows, n=18)
    return fig


# the RTN summary's figures by what they are: its noise is the pixels' temporal noise with the row and column
# terms removed (sqrt of the pixel temporal variance Pt, ares.labels.COMPONENTS), not the dark noise sigma_y.dark
RTN_LABELS = {"rtn_fraction": "RTN pixels / pixels",
              "temporal_noise_dn": "pixel temporal noise sqrt(Pt), all pixels",
              "temporal_noise_without_rtn_dn": "pixel temporal noise sqrt(Pt), RTN pixels left out",
              "temporal_noise_increase_pct": "noise raised by the RTN pixels",
              "median_amplitude_dn": "RTN amplitude (median)"}


def rtn_page(a: dict):
    fig = new_page("Random telegraph noise", f"stage {a.get('stage', '')}: {a.get('frames')} frames, "
                   "1/2/3-level hidden Markov models by BIC on the lag-1 autocorrelation candidates")
    h = a.get("amplitude_hist")
    if h:
        ax = fig.add_axes([0.09, 0.66, 0.38, 0.25])
        labels = [f"{lo:g}-{hi}" for lo, hi in zip(h["edges_sigma"][:-1], h["edges_sigma"][1:])]
        ax.bar(np.arange(len(h["counts"])), h["counts"], color="C0")
        ax.set_xticks(np.arange(len(labels)), labels, rotation=45, fontsize=7)
        ax.set_xlabel("amplitude / within-level sigma")
        ax.set_ylabel("RTN pixels")
        ax.yaxis.get_major_locator().set_params(integer=True)
        ax.set_title("amplitudes", fontsize=9)
        ax.grid(alpha=0.3)
    d = a.get("dwell_hist")
    if d:
        ax2 = fig.add_axes([0.57, 0.66, 0.36, 0.25])
        x = np.arange(len(d["low"]))
        ax2.bar(x - 0.2, d["low"], width=0.4, label="low level", color="C0")
        ax2.bar(x + 0.2, d["high"], width=0.4, label="high level", color="C1")
        labels = [f"{lo:g}-{hi}" for lo, hi in zip(d["edges_frames"][:-1], d["edges_frames"][1:])]
        ax2.set_xticks(x, labels, rotation=45, fontsize=7)
        ax2.set_xlabel("mean dwell (frames)")
        ax2.set_title("dwell times", fontsize=9)
        ax2.yaxis.get_major_locator().set_params(integer=True)
        ax2.legend(fontsize=7)
        ax2.grid(alpha=0.3)
    mp = a.get("map")
    if mp and mp.get("rows"):
        ax3 = fig.add_axes([0.09, 0.29, 0.5, 0.24])
        sc = ax3.scatter(mp["cols"], mp["rows"], c=mp["amplitude"], s=6, cmap="viridis")
        ax3.set_xlim(-0.5, mp["shape"][1] - 0.5)
        ax3.set_ylim(mp["shape"][0] - 0.5, -0.5)
        ax3.set_aspect("equal")
        fig.colorbar(sc, ax=ax3, label="amplitude (DN)")
        ax3.set_title("RTN map", fontsize=9)
    rows = [[RTN_LABELS.get(r[0], r[0])] + r[1:]
            for r in analysis_rows({k: v for k, v in a.items() if isinstance(v, dict) and "value" in v})]
    rows += [["RTN pixels", f"{a.get('rtn_pixels')} of {a.get('pixels')} ({a.get('three_level')} with 3 levels)",
              f"{a.get('candidates')} candidates"]]
    fn = a.get("frames_needed") or {}
    dwell = a.get("frames_needed_dwell_frames") or [math.nan, math.nan]
    rows += [[f"frames needed, amplitude {k} sigma", f"needs >= {v}",
              f"dwell {dwell[0]:.3g}/{dwell[1]:.3g} frames; amplitude to 5 %, dwell to 10 %"] for k, v in fn.items()]
    if "dwell_se_median_pct" in a:  # the measured pixels' own dwell SEs (ares.analysis.lowlight.rtn.dwell_precision)
        need = a.get("dwell_frames_needed", -1)
        rows += [["dwell time SE (median, 10-90 %)", f"{a['dwell_se_median_pct']:.3g} % ({a['dwell_se_p10_pct']:.3g}-"
                  f"{a['dwell_se_p90_pct']:.3g} %)", f"within 10 % for {a.get('dwell_resolved')} of "
                  f"{a.get('rtn_pixels')} RTN pixels"],
                 ["dwell times to 10 % (median pixel)", f"needs >= {need} frames" if need > (a.get("frames") or 0)
                  else f"reached with {a.get('frames')} frames", "the SE falls as 1/sqrt(frames)"]]
    _table(fig, 0.24 if mp and mp.get("rows") else 0.52, rows, n=20)
    return fig
