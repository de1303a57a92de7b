"""The spectral QE report page (EMVA 1288 4.0 Linear, Section 9): QE(lambda) with its
uncertainty as error bars, the wavelengths that are "not available" marked at the axis,
and a table of every wavelength's QE, photons per pixel and net signal with their SEs and
verdict; above it K and where it came from, the photodiode's calibration. Drawn from the
JSON form (``scan_results.json: spectral_qe``); the simulator's truth is never drawn here.
``SPECTRAL_COLUMNS``/``spectral_csv_rows``: ``spectral_qe.csv`` and report.h5's group."""

from __future__ import annotations

import textwrap

from ares.analysis.stats.estimate import Estimate
from ares.report.plots import new_page, text_table


def spectral_qe_page(d: dict):
    fig = new_page("Spectral quantum efficiency",
                   "EMVA 1288 4.0 Linear Section 9: eta = (mu_y - mu_y.dark) / (K mu_p), Eq. (82); "
                   "mu_p from the reference photodiode, Eq. (3)")
    pts = list((d.get("points") or {}).values())
    ok = [(p["wavelength_nm"], Estimate.from_dict(p["qe"])) for p in pts if Estimate.from_dict(p["qe"]).available]
    bad = [p["wavelength_nm"] for p in pts if not Estimate.from_dict(p["qe"]).available]
    ax = fig.add_axes([0.11, 0.60, 0.83, 0.31])
    if ok:
        ax.errorbar([w for w, _ in ok], [e.value for _, e in ok], yerr=[e.se for _, e in ok], fmt="o-", ms=3,
                    lw=1.0, capsize=2, color="C0", label="QE ± SE (measured)")
    if bad:
        ax.plot(bad, [0.0] * len(bad), "x", color="C3", ms=6, label="not available (see the table)")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("quantum efficiency (%)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if ok or bad:
        ax.legend(loc="upper right", fontsize=8)
    K = Estimate.from_dict(d.get("gain_dn_per_e") or {})
    cal = d.get("calibration") or {}
    lines = [f"system gain K = {K.text(with_reason=True)}" + (f" ({d['gain_source']})" if d.get("gain_source") else ""),
             *textwrap.wrap(f"reference photodiode: {cal.get('area_mm2', 0):g} mm^2, reads {cal.get('reading', '?')}, "
                            f"calibration {cal.get('file', '?')} "
                            f"({'-'.join(f'{x:g}' for x in cal.get('range_nm') or [])} nm)", 105,
                            subsequent_indent="    ", break_on_hyphens=False)[:2]]  # (a long path ran off the page)
    hdr = "; ".join(v if k == "title" else f"{k}: {v}" for k, v in cal.get("header") or [])
    if hdr:  # the calibration file's own lines (a certificate's metadata, a table's comments), wrapped
        lines += textwrap.wrap(f"calibration file header: {hdr}", 105, subsequent_indent="    ")[:3]
    if cal.get("uncertainty"):
        lines.append(f"calibration uncertainty: {cal['uncertainty']}")
    lines += [f"WARNING: {w}" for w in d.get("warnings") or []]
    for i, t in enumerate(lines):
        fig.text(0.08, 0.545 - 0.018 * i, t, fontsize=8, va="top")
    rows = []
    for p in pts:
        q, m, s = (Estimate.from_dict(p[k]) for k in ("qe", "mu_p", "net_signal_dn"))
        rows.append([f"{p['wavelength_nm']:g}", "-" if p.get("bandwidth_nm") is None else f"{p['bandwidth_nm']:g}",
                     q.text(), m.text(), s.text(), "ok" if q.available else q.note])
    text_table(fig, (0.06, 0.545 - 0.018 * len(lines) - 0.01, 0.90),
               ["nm", "FWHM nm", "QE (± SE)", "mu_p (± SE)", "net signal (± SE)", "verdict"], rows,
               [6, 8, 13, 18, 16, 39], fontsize=7, title="QE per wavelength", max_chars=[8, 9, 18, 24, 20, 60])
    return fig


SPECTRAL_COLUMNS = ("stage", "wavelength_nm", "bandwidth_nm", "qe_pct", "qe_se_pct", "mu_p_photons",
                    "mu_p_se_photons", "net_signal_dn", "net_signal_se_dn", "u_calibration_pct", "u_gain_pct",
                    "u_signal_pct", "u_photodiode_pct", "verdict")


def spectral_csv_rows(a: dict) -> list[dict]:
    """One row per wavelength: QE, mu_p and the net signal with their SEs, the relative
    uncertainty budget (%) and the verdict (the reason when not available)."""
    rows = []
    for p in (a.get("points") or {}).values():
        q, m, s = p["qe"], p["mu_p"], p["net_signal_dn"]
        b = p.get("budget") or {}
        rows.append({"stage": p["stage"], "wavelength_nm": p["wavelength_nm"], "bandwidth_nm": p.get("bandwidth_nm"),
                     "qe_pct": q.get("value"), "qe_se_pct": q.get("se"), "mu_p_photons": m.get("value"),
                     "mu_p_se_photons": m.get("se"), "net_signal_dn": s.get("value"), "net_signal_se_dn": s.get("se"),
                     **{f"{k}_pct": (100 * b[k] if k in b else None)
                        for k in ("u_calibration", "u_gain", "u_signal", "u_photodiode")},
                     "verdict": q.get("verdict") if q.get("value") is not None else q.get("note", "")})
    return rows
