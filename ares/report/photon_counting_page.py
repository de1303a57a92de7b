"""The photon-counting report page: the code histogram of a low-light stack with the fitted
Poisson-weighted Gaussians (each electron peak and their sum), the Pearson residuals, and a
table of K, read noise, mean electrons and offset beside the photon-transfer estimate (and how
many times finer the histogram's SE is), and the read-noise limit of the method."""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr
from scipy.stats import poisson

from ares.analysis.stats.estimate import Estimate
from ares.analysis.optics.photon_counting import READ_NOISE_LIMIT_E
from ares.report.plots import histogram_residuals, new_page, text_table


def photon_counting_page(stage: str, d: dict):
    fig = new_page(f"Photon-counting histogram: stage {stage}",
                   "code histogram of the low-light stack, Poisson-weighted Gaussians fitted (Starkey & Fossum 2016)")
    est = {k: Estimate.from_dict(d[k]) for k in ("K", "read_noise_e", "mean_e", "offset_dn")}
    hist = d.get("histogram")
    if hist:
        x = np.asarray(hist["codes"], float)
        h = np.asarray(hist["counts"], float)
        m = np.asarray(hist["model"], float)
        ax = fig.add_axes([0.11, 0.55, 0.83, 0.36])
        ax.bar(x, h, width=1.0, color="0.75", label="counts")
        ax.plot(x, m, "-", color="C3", lw=1.2, label=f"fit (chi2/ndf {hist['chi2_ndf']:.2f})")
        if all(e.available for e in est.values()):
            K, s, H, o = (est[k].value for k in ("K", "read_noise_e", "mean_e", "offset_dn"))
            n = h.sum()
            for k in range(int(H + 5 * np.sqrt(H) + 3)):
                c = o + K * k
                comp = n * poisson.pmf(k, H) * (ndtr((x + 0.5 - c) / (K * s)) - ndtr((x - 0.5 - c) / (K * s)))
                ax.plot(x, comp, "--", lw=0.8, color="C0", label="electron peaks" if k == 0 else None)
                if comp.max() > 0.02 * h.max():
                    ax.text(c, comp.max(), f"{k} e-", fontsize=7, ha="center", va="bottom", color="C0")
        ax.set_ylabel("pixels x frames")
        ax.legend(loc="upper right")
        ax.grid(alpha=0.3)
        histogram_residuals(fig, [0.11, 0.40, 0.83, 0.12], ax, x, h, m, "code (DN)")
    pt = {k: Estimate.from_dict(v) for k, v in (d.get("photon_transfer") or {}).items()}
    names = {"K": "gain K (DN/e-)", "read_noise_e": "read noise (e-)", "mean_e": "mean electrons (e-)",
             "offset_dn": "offset (DN)"}
    rows = [[names[k], e.text(with_unit=False), pt[k].text(with_unit=False) if k in pt else "-",
             _finer(e, pt.get(k)), _verdict(d[k], e)] for k, e in est.items()]
    y0 = 0.33 if hist else 0.9
    yb = text_table(fig, (0.08, y0, 0.86), ["quantity", "histogram fit (± SE)", "photon transfer (± SE)",
                                       "SE ratio", "verdict"],
               rows, [17, 17, 18, 10, 24], fontsize=8, title="Photon counting beside photon transfer",
               max_chars=[24, 24, 24, 12, 60])
    fig.text(0.08, yb - 0.01, f"SE ratio: photon transfer's SE over the histogram's (how many times finer the "
             f"histogram measures).\nThe electron peaks are separated below ~{READ_NOISE_LIMIT_E:g} e- read noise; "
             "above it the fit says \"not available\" and photon transfer is the estimate.",
             fontsize=7.5, va="top", color="0.25")
    return fig


def _finer(e: Estimate, other: Estimate | None) -> str:
    if other is None or not (e.available and other.available) or not e.se > 0:
        return "-"
    return f"{other.se / e.se:.1f}x"


def _verdict(d: dict, e: Estimate) -> str:
    """The table's verdict: "ok", the reason it is not available, or that its precision is
    not enough (analysis.optics.photon_counting.K_TARGET / RN_TARGET) and what would reach it."""
    if not e.available:
        return e.note
    if "precision" in d:
        return f"{d['verdict']}: {d['precision']}"
    return d.get("verdict", "ok")
