"""What ``ares run`` prints at the end of a run: the headline figures (one list with --json and
the window, ``ares.report.headline``), each analysis's estimates, the precision plan, the limits
verdict. May import what ``ares.commands.run`` may."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ares.analysis.stats.estimate import format_dict


def _num(d) -> str:
    """An estimate's JSON form as text: digits from its SE, limits as < / >, n/a + why."""
    return format_dict(d, with_reason=True)


def print_summary(outcome, scan, seconds: float, out=None, resumed: int = 0) -> None:
    """``resumed``: stages committed before this session (``ares resume``): the time is this
    session's, so it is charged to the stages it ran, not to the run's total."""
    out = out or sys.stdout
    res = outcome.scan_results
    n = len(outcome.stages)
    count = f"{n} stage(s) in {seconds:.1f} s" if not resumed else \
        f"{n} stage(s): {n - resumed} run now in {seconds:.1f} s after {resumed} resumed from the run directory"
    out.write(f"\n{scan.name}: {outcome.status}, {count}"
              f"{', seed ' + str(outcome.seed) if outcome.seed is not None else ''}\n")
    if outcome.run_dir:
        out.write(f"run directory: {outcome.run_dir}\n")
        from ares.hardware.link_stats import device_lines, link_lines

        meta = _read_meta(Path(outcome.run_dir))  # what each device said it is, what each link did
        for label, text in device_lines(meta) + link_lines(meta):
            out.write(f"{label}: {text}\n")
    lost = [(st.get("name"), x) for st in outcome.stages for x in st.get("frames_lost", ())]
    if lost:
        kinds = ", ".join(f"{x['kind']} {x['count']}" for _, x in lost)
        names = ", ".join(sorted({str(n) for n, _ in lost}))
        why = "<frames on_loss='regrab'>" if scan.on_loss == "regrab" else "a transient fault under <suspend device>"
        out.write(f"frames lost: {kinds}; stage(s) {names} acquired again ({why})\n")
    print_headline(res, out)
    for name, r in res.items():
        if name in ("ptc", "decomposition") or not isinstance(r, dict):
            continue
        if r.get("status"):
            out.write(f"{name}: {r['status']}{' (' + r['note'] + ')' if r.get('note') else ''}\n")
            continue
        out.write(f"{analysis_title(name)}:\n")
        _print_estimates(r, out, "  ", path=name)
    for f in outcome.limit_failures:
        out.write(f"LIMIT FAILED: {f}\n")
    if outcome.run_dir:
        meta = _read_meta(Path(outcome.run_dir))
        if meta.get("report_error"):
            out.write(f"report: not written ({meta['report_error']})\n")
    from ares.results.registry import limits_verdict

    out.write(limits_verdict(outcome.status, len(scan.limits), outcome.limit_failures)["text"] + "\n")


from ares.labels import ANALYSIS_TITLES, defect_count_unit  # noqa: E402
from ares.labels import analysis_title  # noqa: E402,F401


def print_headline(res: dict, out) -> None:
    """The photon-transfer figures, SNR max, DSNU and PRNU (``ares.report.headline``: the
    window's and --json's list), then the decomposition's components."""
    from ares import labels
    from ares.report.headline import full_well_note, headline, same_point

    rows = headline(res)
    w = max([len(n) for _, n, _ in rows] + [len(lb) for _, lb in labels.PTC_FIGURES])
    p = res.get("ptc")
    if isinstance(p, dict) and "gain_dn_per_e" in p:
        out.write("photon transfer:\n")
        for key, name, d in rows:
            if key in labels.PTC_LABELS or key in labels.SNR_FIGURES:
                out.write(f"  {name:<{w}} {_num(d)}\n")
        for label, text in (("same level", same_point(p)), ("full well", full_well_note(p))):
            if text:
                out.write(f"  {label:<{w}} {text}\n")
        for label, key in (("gain model", "gain_model"), ("linearity (Eq. 51)", "linearity_check_text"),
                           ("linearity (ARES option)", "linearity_check"), ("saturation", "saturation")):
            if isinstance(p.get(key), dict):
                out.write(f"  {label:<{w}} {p[key].get('reason') or p[key].get('note')}\n")
        if isinstance(p.get("gain_headline"), dict) and p["gain_headline"].get("statement"):
            # beside the EMVA 1288 4.0 Eq. 50 K (a scan with emva4): which is the headline and why
            out.write(f"  {'headline K':<{w}} {p['gain_headline']['statement']}\n")
    elif isinstance(p, dict):
        out.write(f"photon transfer: {p.get('note', p.get('status'))}\n")
    d = res.get("decomposition")
    if isinstance(d, dict) and "components" in d:
        sets = ", ".join(f"{k.removeprefix('reg:')}={v:g}" for k, v in d["settings"].items())
        out.write(f"nonuniformity at stage {d['stage']}:\n")
        for key, name, e in rows:
            if key in labels.HEADLINE_FIGURES and key not in labels.SNR_FIGURES:
                out.write(f"  {name:<{w}} {_num(e)}\n")
        out.write(f"noise components at stage {d['stage']} ({sets}):\n")
        if "masked_pixels" in d:
            u = {k: v.get("value") for k, v in (d.get("components_unmasked") or {}).items()}
            src = d.get("mask_source") + (f", provisional: {d['provisional']}" if d.get("provisional") else "")
            classes = ", ".join(f"{k} {v}" for k, v in (d.get("mask_classes") or {}).items())
            out.write(f"  {d['masked_pixels']} {labels.MASKED_PIXELS} (mask from {src}"
                      f"{': ' + classes if classes else ''}; the defect analysis classifies on its own); "
                      f"with them: Ps {u.get('Ps', float('nan')):.4g} DN^2, Pt {u.get('Pt', float('nan')):.4g} DN^2\n")
            for cls, why in (d.get("mask_incomplete") or {}).items():  # Ps an upper limit (defect_mask.bound_incomplete)
                out.write(f"  mask incomplete, {cls}: {why}; the masked Ps is an upper limit\n")
        elif d.get("mask_note"):
            out.write(f"  {d['mask_note']}\n")
        from ares.report.tables import component_label, component_text

        part = "flat_anova" if d.get("scene") == "flat" and "G" not in d["components"] else "components"
        for k, v in d["components"].items():  # (a lit stack without a matched dark: its Pt holds the shot noise)
            out.write(f"  {k:<14} {component_text(k, v):<34} {component_label(k, part)}\n")


def print_precision(rep: dict, out=None) -> None:
    """The precision-driven scan's plan and what it reached, one line per target."""
    out = out or sys.stdout
    if "targets" not in rep:
        out.write(f"precision: {rep.get('status')}: {rep.get('message', '')}\n")
        return
    out.write(f"precision: {rep['frames_per_stage']} frames per stage ({rep['pilot_frames']} pilot + "
              f"{rep['frames_per_stage'] - rep['pilot_frames']} more; budget {rep['budget']}), "
              f"{'every target met' if rep['all_met'] else 'NOT every target met'}\n")
    for t in rep["targets"]:
        se = t["se"]
        got = "n/a" if se is None else (f"{100 * t['se_rel']:.3g} %" if t["target"].endswith("%") else f"{se:.3g}")
        out.write(f"  {t['quantity']:<24} SE {got:<10} target {t['target']:<8} {'met' if t['met'] else 'NOT met'}"
                  f"{' (' + t['note'] + ')' if t['note'] else ''}\n")


def _read_meta(run_dir: Path) -> dict:
    try:
        return json.loads((run_dir / "run.json").read_text())
    except (OSError, ValueError):
        return {}


def _print_estimates(d: dict, out, indent: str, depth: int = 0, path: str = "") -> None:
    """Estimates (``{"value", "se", "unit"}``) of an analysis result, nested up to five levels
    (the MTF's stages -> stage -> channels -> channel -> its option beside the standard)."""
    for k, v in d.items():
        if isinstance(v, dict) and "value" in v and "unit" in v:
            if path in ("emva4.values", "emva4.general.values"):  # the standard's symbols, as every surface
                from ares.analysis.emva.sheet import symbol

                k = symbol(k, path == "emva4.general.values")
            out.write(f"{indent}{k:<26} {_num(v)}\n")
        elif isinstance(v, dict) and depth < 5 and any(isinstance(x, dict) for x in v.values()):
            label = (f"option esf_half_width={v['esf_half_width']:g} px (not the standard)"
                     if k == "option" and "esf_half_width" in v else
                     analysis_title(f"{path}.{k}") if f"{path}.{k}" in ANALYSIS_TITLES else k)
            out.write(f"{indent}{label}:\n")
            _print_estimates(v, out, indent + "  ", depth + 1, f"{path}.{k}")
        elif isinstance(v, (int, str)) and not isinstance(v, bool) and k in ("counts", "dark_stage"):
            out.write(f"{indent}{k:<26} {v}\n")
        elif k == "counts" and isinstance(v, dict):
            out.write(f"{indent}{'defective pixels':<26} " + ", ".join(  # counts, each with its unit
                f"{a} {b} {defect_count_unit(a)}" for a, b in v.items() if b) + "\n")
        elif k == "unavailable" and isinstance(v, dict):
            for a, why in v.items():
                out.write(f"{indent}{a + ': n/a':<26} {why}\n")
        elif k == "warnings" and isinstance(v, list):
            for w in v:
                out.write(f"{indent}WARNING: {w}\n")
