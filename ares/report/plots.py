"""Matplotlib figures of the report (plain ``Figure`` objects, no pyplot, no Qt).

Every function draws onto axes it is given from numbers already computed; none reads
files. Pages are A4 portrait (``new_page``).
"""

from __future__ import annotations

from ares import labels

import math
import textwrap

import matplotlib.lines
import matplotlib.patches
import numpy as np
from matplotlib.figure import Figure

A4 = (8.27, 11.69)
STATUS_STYLE = {"fit": dict(marker="o", color="C0", label="fitted"),
                "valid": dict(marker="s", color="C2", label="valid, not fitted"),
                "excluded": dict(marker="x", color="C3", label="excluded")}
RC = {"font.size": 9, "axes.titlesize": 10, "axes.labelsize": 9, "legend.fontsize": 8,
      # Type 3 font subsets: 1 s less per report than Type 42 (TrueType subsetting), text still
      # extractable; titles at a fixed height: no tight-bbox search of every axes per title
      "pdf.fonttype": 3, "axes.titley": 1.0}


def new_page(title: str, subtitle: str = "") -> Figure:
    fig = Figure(figsize=A4)
    fig.text(0.5, 0.975, title, ha="center", va="top", fontsize=14, weight="bold")
    if subtitle:
        fig.text(0.5, 0.952, subtitle, ha="center", va="top", fontsize=9, color="0.3")
    return fig


def save_pdf(figs: list, path, title: str, creator: str) -> None:
    """Write ``figs`` to the PDF ``path`` (tmp -> rename); one InputError sentence if it cannot."""
    from pathlib import Path

    from matplotlib.backends.backend_pdf import PdfPages

    from ares.errors import InputError

    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with PdfPages(tmp, metadata={"Title": title, "Creator": creator}) as pdf:
            for fig in figs:
                pdf.savefig(fig)
        tmp.replace(path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(f"{path}: cannot write the PDF ({exc.strerror or exc})") from None


def clip(s: str, n: int) -> str:
    s = str(s)
    return s if len(s) <= n else s[: n - 1] + "…"


def cell_lines(cell, n: int | None) -> list[str]:
    """A table cell wrapped to ``n`` characters a line (never cut: a note's verdict is in its end)."""
    text = str(cell)
    return (textwrap.wrap(text, n, break_on_hyphens=False) or [""]) if n else [text]


def row_lines(row, max_chars: list[int] | None) -> int:
    """The lines a wrapped table row takes."""
    return max((len(cell_lines(c, max_chars[j] if max_chars else None)) for j, c in enumerate(row)), default=1)


def paginate(rows: list, max_chars: list[int] | None, first: float, then: float) -> list[list]:
    """``rows`` of a wrapped ``text_table`` in page-sized chunks: ``first`` lines of room on the
    first page, ``then`` on each further one; a row (with its wrapped lines) is never split (the
    first page may get none when its room is short; a row longer than a whole page has one)."""
    chunks: list[list] = [[]]
    room = first
    for row in rows:
        n = row_lines(row, max_chars)
        if n > room and (chunks[-1] or room < then):
            chunks.append([])
            room = then
        chunks[-1].append(row)
        room -= n
    return chunks


def table_lines_between(top: float, bottom: float, fontsize: float, title: bool) -> float:
    """The rows' lines a ``text_table`` (wrapped) has room for from ``top`` down to ``bottom`` on an A4 page."""
    return (top - bottom) / (fontsize * 1.45 / 72 / A4[1]) - table_head_lines(title)


def table_head_lines(title: bool) -> float:
    """The lines ``text_table`` takes above its first row (title, header, rule)."""
    return (1.5 if title else 0.0) + 1.2


def text_table(fig: Figure, rect, header: list[str], rows: list[list[str]], widths: list[float],
               fontsize: float = 8, title: str = "", max_chars: list[int] | None = None,
               wrap: bool = False) -> float:
    """Draw a table as aligned text in ``rect`` (figure fraction: left, top, width);
    returns the y (figure fraction) below the last row. Cells longer than ``max_chars``
    are cut with "…", or with ``wrap`` continued on the lines below (the row's shading
    spans them)."""
    left, top, width = rect
    line = fontsize * 1.45 / 72 / fig.get_figheight()
    y = top
    if title:
        fig.text(left, y, title, fontsize=fontsize + 2, weight="bold", va="top")
        y -= line * 1.5
    xs = [left + width * sum(widths[:i]) / sum(widths) for i in range(len(widths))]
    for x, h in zip(xs, header):
        fig.text(x, y, h, fontsize=fontsize, weight="bold", va="top")
    y -= line * 0.9
    fig.add_artist(matplotlib.lines.Line2D([left, left + width], [y, y], color="0.5", lw=0.6))
    y -= line * 0.3
    for k, row in enumerate(rows):
        n = row_lines(row, max_chars) if wrap else 1
        if k % 2:
            fig.add_artist(matplotlib.patches.Rectangle((left, y - line * (n - 0.05)), width, line * n, color="0.94",
                                                        zorder=-1, transform=fig.transFigure))
        for j, (x, cell) in enumerate(zip(xs, row)):
            mono = "monospace" if j and j < 2 else None
            if wrap:
                for i, part in enumerate(cell_lines(cell, max_chars[j] if max_chars else None)):
                    fig.text(x, y - i * line, part, fontsize=fontsize, va="top", family=mono)
                continue
            txt = clip(cell, max_chars[j]) if max_chars else str(cell)
            fig.text(x, y, txt, fontsize=fontsize, va="top", family=mono)
        y -= line * n
    return y


# ------------------------------------------------------------------ PTC

def _status_scatter(ax, x, y, status, yerr=None):
    for st, style in STATUS_STYLE.items():
        sel = np.array([s == st for s in status])
        if not sel.any():
            continue
        kw = dict(ls="none", ms=5, mfc="none" if st == "valid" else None, **style)
        if yerr is not None:
            ax.errorbar(np.asarray(x)[sel], np.asarray(y)[sel], yerr=np.asarray(yerr)[sel], capsize=2, **kw)
        else:
            ax.plot(np.asarray(x)[sel], np.asarray(y)[sel], **kw)


def ptc_variance(ax, rows: list[dict], res, title: str) -> list[str]:
    """Variance vs signal (dark subtracted) with the gain fits; excluded levels marked
    with a number that keys the reasons returned (one string each)."""
    S = np.array([r["signal_dn"] for r in rows])
    V = np.array([r["variance_dn2"] for r in rows])
    E = np.array([r["variance_se_dn2"] for r in rows])
    status = [r["status"] for r in rows]
    _status_scatter(ax, S, V, status, E)
    notes = []
    if res is not None:
        fit = [lv for lv in res.levels if lv.status == "fit"]
        smax = max([lv.signal for lv in res.levels if lv.status != "excluded"] or [1.0])
        xs = np.linspace(0, smax * 1.05, 50)
        head = {"line": "WLS line", "astier": "Astier", "ols": "OLS line"}.get(res.gain_headline().get("estimator"), "line")
        for e, name, ls in ((res.gain_dn_per_e, f"headline ({head})", "-"),
                            (res.gain_origin_dn_per_e, "EMVA origin fit", "--"),
                            (res.gain_astier_dn_per_e, "Astier", ":")):
            if e.available:  # each K with the digits its SE supports, as in the tables
                ax.plot(xs, e.value * xs, ls=ls, lw=1, color="0.2" if ls == "-" else "0.5",
                        label=f"{name}: K = {e.text()}")
        if fit:
            ax.axvspan(0, max(lv.signal for lv in fit), color="C0", alpha=0.05, lw=0)
    k = 0
    marks: list[list] = []  # [x, y, [numbers]]: excluded levels that would overprint share one label
    xs_all = [r["signal_dn"] for r in rows if np.isfinite(r["signal_dn"])]
    ys_all = [r["variance_dn2"] for r in rows if np.isfinite(r["variance_dn2"])]
    dx = 0.03 * (max(xs_all) - min(xs_all)) if xs_all else 0.0
    dy = 0.05 * (max(ys_all) - min(ys_all)) if ys_all else 0.0
    for r in rows:
        if r["status"] == "excluded" and np.isfinite(r["signal_dn"]) and np.isfinite(r["variance_dn2"]):
            k += 1
            x, y = r["signal_dn"], r["variance_dn2"]
            near = next((m for m in marks if abs(m[0] - x) <= dx and abs(m[1] - y) <= dy), None)
            if near is None:
                marks.append([x, y, [k]])
            else:
                near[2].append(k)
            notes.append(f"{k}: {r['stage']} -- {r['reason']}")
    for x, y, ks in marks:
        text = str(ks[0]) if len(ks) == 1 else (f"{ks[0]}-{ks[-1]}" if ks == list(range(ks[0], ks[-1] + 1))
                                                else ",".join(map(str, ks)))
        ax.annotate(text, (x, y), textcoords="offset points", xytext=(3, 4), fontsize=7, color="C3")
    ax.set_xlabel("signal  mu_y - mu_dark  (DN)")
    ax.set_ylabel("temporal variance  s2_y - s2_dark  (DN^2)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    return notes


def noise_zones(ax, rows: list[dict], res, title: str) -> None:
    """log-log noise vs signal: temporal, total (temporal + spatial) and the total-noise
    model with its read / shot / PRNU zones."""
    good = [lv for lv in res.levels if lv.status != "excluded" and lv.signal > 0] if res else []
    if not good:
        ax.text(0.5, 0.5, "no valid levels", ha="center", transform=ax.transAxes)
        return
    S = np.array([lv.signal for lv in good])
    tot = np.sqrt(np.array([lv.total_var + (lv.spatial_var if math.isfinite(lv.spatial_var) else 0)
                            for lv in good]))
    tmp = np.sqrt(np.array([lv.total_var for lv in good]))
    ax.loglog(S, tmp, "o", ms=4, color="C0", label="temporal noise")
    ax.loglog(S, tot, "s", ms=4, mfc="none", color="C1", label="total noise (temporal + spatial)")
    K = res.gain_dn_per_e
    xs = np.geomspace(S.min() / 2, S.max() * 1.5, 200)
    if K.available:
        ne = xs / K.value
        ax.loglog(xs, np.sqrt(K.value * xs), ":", color="C0", lw=1, label="shot noise sqrt(K S)")
        nm = res.noise_model
        sn, pr = nm.get("sensor_noise_e"), nm.get("prnu_pct")
        if sn is not None and sn.available:
            ax.axhline(sn.value * K.value, color="0.4", lw=0.8, ls="--", label=f"sensor noise (total-noise model) = {sn.text()}")
        if sn is not None and pr is not None and sn.available and pr.available:
            model = np.sqrt(sn.value**2 + ne + (pr.value / 100 * ne) ** 2) * K.value
            ax.loglog(xs, model, "-", color="C1", lw=1.2, label=f"total-noise model, {labels.figure_name('noise_model.prnu_pct')} = {pr.text()}")
            ax.loglog(xs, pr.value / 100 * xs, "-.", color="C2", lw=0.8, label="PRNU noise")
        lo, hi = xs[0], xs[-1]
        edges = [lo]
        for key in ("read_to_shot_e", "shot_to_prnu_e"):
            z = res.zones.get(key)
            if z is not None and z.available and lo < z.value * K.value < hi:
                edges.append(z.value * K.value)
                ax.axvline(z.value * K.value, color="0.3", lw=0.8)
        edges.append(hi)
        for (a, b), name, c in zip(zip(edges[:-1], edges[1:]), ("read", "shot", "PRNU"), ("0.85", "C0", "C2")):
            ax.axvspan(a, b, color=c, alpha=0.07, lw=0)
            ax.text(math.sqrt(a * b), 0.97, f"{name} zone", transform=ax.get_xaxis_transform(), ha="center",
                    va="top", fontsize=8)
    ymin = max(min(tmp.min(), tot.min()) / 3, 1e-3)
    ax.set_ylim(ymin, max(tot.max(), tmp.max()) * 3)
    ax.set_xlabel("signal (DN)")
    ax.set_ylabel("noise (DN rms)")
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="lower right")


def snr_curve(ax, res, title: str) -> None:
    s, snr = res.snr["signal_dn"], res.snr["snr"]
    K = res.gain_dn_per_e
    if K.available and len(res.snr["signal_e"]):
        x, xl = res.snr["signal_e"], "signal (e-)"
    else:
        x, xl = s, "signal (DN)"
    ok = (x > 0) & (snr > 0)
    ax.loglog(x[ok], snr[ok], "o", ms=4, label="measured  S / temporal noise")
    if K.available and ok.any():
        xs = np.geomspace(x[ok].min(), x[ok].max(), 100)
        ax.loglog(xs, np.sqrt(xs), ":", color="0.4", label="ideal (shot-noise limit) sqrt(N)")
        rn = res.read_noise_e
        if rn.available:
            ax.loglog(xs, xs / np.sqrt(xs + rn.value**2), "-", color="C1", lw=1,
                      label=f"shot + read noise ({rn.value:.3g} e-)")
    if ok.any():
        i = int(np.argmax(snr))
        ax.annotate(f"max {snr[i]:.3g} ({20 * math.log10(snr[i]):.1f} dB)", (x[i], snr[i]),
                    textcoords="offset points", xytext=(-110, -4), fontsize=8)
    ax.set_xlabel(xl)
    ax.set_ylabel("SNR")
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="upper left")


def linearity(ax, ax_dev, rows: list[dict], title: str) -> None:
    if all(r["photons"] is not None for r in rows):
        x, xl = np.array([r["photons"] for r in rows], float), "photons per pixel (light x exposure)"
        per = "DN per photon/pixel"
    else:
        x, xl = np.array([r["exposure_s"] for r in rows], float), "exposure (s)"
        per = "DN/s"
    S = np.array([r["signal_dn"] for r in rows])
    status = [r["status"] for r in rows]
    _status_scatter(ax, x, S, status)
    good = np.array([s != "excluded" for s in status]) & np.isfinite(x)
    ax.set_ylabel("signal (DN)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    if good.sum() >= 3:
        smax = S[good].max()
        sel = good & (S >= 0.05 * smax) & (S <= 0.95 * smax)
        if sel.sum() >= 2:
            a, b = np.polyfit(x[sel], S[sel], 1, w=1.0 / S[sel])
            xs = np.linspace(0, x[good].max(), 50)
            ax.plot(xs, a * xs + b, "-", color="0.3", lw=1, label=f"line on 5-95 % (slope {a:.4g} {per})")
            dev = 100 * (S - (a * x + b)) / (a * x + b)
            _status_scatter(ax_dev, x, dev, status)
            ax_dev.axhline(0, color="0.3", lw=0.8)
            for yy in (-1, 1):
                ax_dev.axhline(yy, color="0.6", lw=0.6, ls="--")
            lim = max(2.0, float(np.nanmax(np.abs(dev[sel]))) * 1.5)
            ax_dev.set_ylim(-lim, lim)
            ax_dev.axvspan(x[sel].min(), x[sel].max(), color="C0", alpha=0.05, lw=0)
    if good.any():
        hidden = int(np.sum(np.isfinite(x) & (x > x[good].max() * 1.15)))
        pos = x[good & (x > 0)]
        # signal vs illumination on linear axes (EMVA 1288's linearity graph): on a log x axis
        # the fitted line (with its offset) looks curved. The deviation panel below takes a log
        # x axis for a log-spaced sweep, so that its low levels are not crowded at 0.
        ax.set_xlim(-0.02 * x[good].max(), x[good].max() * 1.15)
        if pos.size >= 2 and pos.max() / pos.min() > 100:
            ax_dev.set_xscale("log")
            ax_dev.set_xlim(pos.min() / 1.5, x[good].max() * 1.3)
        else:
            ax_dev.set_xlim(-0.02 * x[good].max(), x[good].max() * 1.15)
        if hidden:
            ax.text(0.98, 0.03, f"{hidden} excluded level(s) beyond the axis", transform=ax.transAxes,
                    ha="right", fontsize=7, color="C3")
    ax.legend(loc="upper left")
    ax.set_xlabel(xl, fontsize=8)
    ax_dev.set_xlabel(xl)
    ax_dev.set_ylabel("deviation from line (%)")
    ax_dev.grid(alpha=0.3)


# ------------------------------------------------------------------ maps

def image_with_hist(fig, ax_img, ax_hist, a: np.ndarray, title: str, unit: str) -> None:
    a = np.asarray(a, float)
    fin = a[np.isfinite(a)]
    if fin.size == 0:
        ax_img.text(0.5, 0.5, "no data", ha="center", transform=ax_img.transAxes)
        return
    lo, hi = np.percentile(fin, [0.5, 99.5])
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    im = ax_img.imshow(a, vmin=lo, vmax=hi, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax_img, fraction=0.046, pad=0.04, label=unit)
    ax_img.set_title(title)
    ax_img.set_xlabel("column")
    ax_img.set_ylabel("row")
    # the histogram's range: the bulk (0.1-99.9 %, widened by half its width) so that a few
    # defect pixels far out do not squash it; the pixels outside are counted, not hidden
    q0, q1 = np.percentile(fin, [0.1, 99.9])
    pad = 0.5 * max(q1 - q0, 1e-12)
    rng = (q0 - pad, q1 + pad)
    out = int(np.count_nonzero((fin < rng[0]) | (fin > rng[1])))
    # one filled step path, not 128 bar patches (a quarter of a maps page's drawing time)
    counts, edges = np.histogram(fin, bins=128, range=rng)
    ax_hist.stairs(np.where(counts > 0, counts, 0.5), edges, fill=True, baseline=0.5, color="C0")
    ax_hist.set_yscale("log")
    ax_hist.axvline(np.mean(fin), color="C3", lw=0.8)
    mad = 1.4826 * float(np.median(np.abs(fin - np.median(fin))))
    ax_hist.set_title(f"histogram\nmean {np.mean(fin):.4g}, sd {np.std(fin):.3g} (robust {mad:.3g}) {unit}",
                      fontsize=9)
    if out:
        ax_hist.text(0.98, 0.97, f"{out} pixel(s) outside\n[{rng[0]:.4g}, {rng[1]:.4g}]", transform=ax_hist.transAxes,
                     ha="right", va="top", fontsize=7, color="C3")
    ax_hist.set_xlabel(unit)
    ax_hist.set_ylabel("pixels")
    ax_hist.grid(alpha=0.3)


def grid_image(fig, ax, values: np.ndarray, xvals, yvals, xlabel: str, ylabel: str, title: str, unit: str) -> None:
    im = ax.imshow(values, origin="lower", aspect="auto", cmap="viridis", interpolation="nearest")
    ax.set_xticks(range(len(xvals)), [f"{v:.3g}" for v in xvals], rotation=45, ha="right")
    ax.set_yticks(range(len(yvals)), [f"{v:.3g}" for v in yvals])
    for (i, j), v in np.ndenumerate(values):
        if np.isfinite(v):
            txt = f"{v:.0f}" if 1000 <= abs(v) < 1e6 else f"{v:.3g}"
            ax.text(j, i, txt, ha="center", va="center", fontsize=6 if values.shape[1] > 4 else 7, color="w")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label=unit)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)


def histogram_residuals(fig, rect, ax, x, h, m, xlabel: str):
    """The panel under a fitted histogram: each bin's (count - model) / sqrt(model), sharing
    ``ax``'s x axis (photon counting, Fe-55)."""
    ax2 = fig.add_axes(rect, sharex=ax)
    ax2.plot(x, (h - m) / np.sqrt(np.maximum(m, 1.0)), ".", ms=3, color="k")
    ax2.axhline(0, color="0.5", lw=0.6)
    ax2.set_ylabel("residual / sqrt(model)")
    ax2.set_xlabel(xlabel)
    ax2.grid(alpha=0.3)
    return ax2
