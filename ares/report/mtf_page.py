"""The MTF report page: each channel's e-SFR curve with MTF50 and the Nyquist frequency
marked, and a table of MTF50, MTF at Nyquist and the edge angle with their SEs (or "not
available" and why). Drawn from the JSON form (``SfrResult.to_dict``), so the scan report
and ``ares mtf --pdf`` draw the same page."""

from __future__ import annotations

import textwrap

from ares.analysis.stats.estimate import Estimate
from ares.report.plots import new_page, text_table


def mtf_page(channels: dict[str, dict], title: str, subtitle: str = ""):
    """``channels``: name -> ``SfrResult.to_dict()`` (with the curve)."""
    fig = new_page(title, subtitle or "slanted edge, ISO 12233 e-SFR (4x oversampled ESF)")
    ax = fig.add_axes([0.11, 0.50, 0.83, 0.40])
    nyqs = set()
    for i, (name, d) in enumerate(channels.items()):
        f, m = d.get("freq_cy_per_px"), d.get("mtf")
        if not f:
            continue
        line, = ax.plot(f, m, "-", lw=1.2, label=name)
        e50 = Estimate.from_dict(d["mtf50_cy_per_px"])
        if e50.available:
            ax.plot([e50.value], [0.5], "o", color=line.get_color(), ms=5)
            ax.annotate(f"MTF50 {e50.value:.3f}", (e50.value, 0.5), textcoords="offset points",
                        xytext=(8, 4 + 10 * i), fontsize=7, color=line.get_color())
        en = Estimate.from_dict(d["mtf_at_nyquist"])
        if en.available:
            ax.plot([d["nyquist_cy_per_px"]], [en.value], "s", color=line.get_color(), ms=4)
        nyqs.add(d["nyquist_cy_per_px"])
        o = d.get("option") or {}
        if o.get("freq_cy_per_px"):
            ax.plot(o["freq_cy_per_px"], o["mtf"], ":", lw=1.0, color=line.get_color(),
                    label=f"{name}, {_option_label(o)} (esf_half_width, not the standard)")
    for n in sorted(nyqs):
        ax.axvline(n, color="0.4", ls="--", lw=0.8)
        ax.text(n, 1.02, f" Nyquist {n:g}", fontsize=7, color="0.3", va="bottom")
    ax.axhline(0.5, color="0.7", lw=0.6)
    ax.set_xlim(0, max([2 * n for n in nyqs] or [1.0]))
    ax.set_ylim(0, 1.1)
    ax.set_xlabel("spatial frequency (cycles per sensor pixel, along the edge normal)")
    ax.set_ylabel("MTF (SFR)")
    ax.grid(alpha=0.3)
    if any(d.get("freq_cy_per_px") for d in channels.values()):
        ax.legend(loc="center right")
    rows = []
    for name, d in channels.items():
        for label, e in [(name, d)] + ([(f"{name}, {_option_label(d['option'])}", d["option"])] if d.get("option") else []):
            ests = [Estimate.from_dict(e[k]) for k in ("mtf50_cy_per_px", "mtf_at_nyquist", "angle_deg")]
            why = next((x.note for x in ests if not x.available), "ok")
            rows.append([label] + [x.text(with_unit=False) for x in ests] + [why])
    y = text_table(fig, (0.08, 0.43, 0.86), ["channel", "MTF50 (cy/px)", "MTF at Nyquist", "edge angle (deg)",
                                             "verdict"], rows, [19, 17, 15, 16, 33], fontsize=8,
                   title="MTF figures (± SE)", max_chars=[24, 22, 20, 20, 60])
    opts = [d["option"] for d in channels.values() if d.get("option")]
    if opts:
        hw = f"{opts[0].get('esf_half_width'):g}"
        note = (f"A channel's first row is ISO 12233 e-SFR as the standard bins it (the whole region); the row "
                f"\"option {hw} px\" (esf_half_width={hw}) keeps only the ESF within {hw} pixels of the edge: not the "
                "standard, less noise in the LSF window (benchmarks/beyond_linear.md measures both against the "
                "simulator's truth and says which meets MTF50 within 2 %).")
        fig.text(0.08, y - 0.015, textwrap.fill(note, 125), fontsize=7, color="0.3", va="top")
    return fig


def _option_label(o: dict) -> str:
    return f"option {o.get('esf_half_width'):g} px"


MTF_COLUMNS = ("stage", "channel", "freq_cy_per_px", "mtf", "mtf50_cy_per_px", "mtf50_se", "mtf_at_nyquist",
               "mtf_at_nyquist_se", "verdict", "esf_half_width_px")


def mtf_csv_rows(a: dict) -> list[dict]:
    """``mtf.csv``: each stage's and channel's curve; the first row of each carries MTF50 and
    MTF at Nyquist with their SEs and verdict (the reason when not available); the option
    ``esf_half_width``'s rows follow the standard's, that column holding its value (empty: the
    standard)."""
    rows = []
    for stage, s in (a.get("stages") or {}).items():
        for ch, dd in s["channels"].items():
            for d in [dd] + ([dd["option"]] if dd.get("option") else []):
                e50, en = d["mtf50_cy_per_px"], d["mtf_at_nyquist"]
                key = {"stage": stage, "channel": ch, "esf_half_width_px": d.get("esf_half_width")}
                head = {**key, "mtf50_cy_per_px": e50.get("value"), "mtf50_se": e50.get("se"),
                        "mtf_at_nyquist": en.get("value"), "mtf_at_nyquist_se": en.get("se"),
                        "verdict": e50.get("note", "") if e50.get("value") is None else e50.get("verdict", "")}
                curve = list(zip(d.get("freq_cy_per_px") or [], d.get("mtf") or []))
                if not curve:
                    rows.append(head)
                for i, (f, m) in enumerate(curve):
                    rows.append({**(head if i == 0 else key), "freq_cy_per_px": f, "mtf": m})
    return rows
