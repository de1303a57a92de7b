"""The headline figures of a scan's results, one list for every surface: the terminal's
summary (``ares run``), its ``--json``, the window's Information tab and the report's key
figures take their names (``ares.labels.FIGURES``), order and values from here.

``nonuniformity`` turns the decomposition's variances into DSNU (e- rms and DN rms) and
PRNU (% rms), with defects excluded and with every pixel, each under its own name; where
the scan had no defect mask the "defects excluded" figures are not available and say why
(``labels.MASK_POLICY``).
"""

from __future__ import annotations

import math

from ares import labels
from ares.analysis.stats.estimate import VERDICT_UPPER, Estimate

NO_MASK = "no defect mask in this scan"


def _est(d) -> Estimate | None:
    return Estimate.from_dict(d) if isinstance(d, dict) and "unit" in d else None


def _dsnu(ps: dict | None, gain: Estimate | None, which: str, stage: str) -> tuple[Estimate, Estimate]:
    """(DSNU in e- rms, in DN rms) from the pixel offset FPN variance ``ps`` (DN^2)."""
    if not isinstance(ps, dict) or ps.get("value") is None:
        why = f"no pixel offset FPN at stage {stage}"
        return Estimate.na(why, "e-"), Estimate.na(why, "DN")
    v, se = float(ps["value"]), ps.get("se")
    se = float(se) if se is not None else math.nan
    if v <= 0:
        why = f"pixel offset FPN variance not above 0 at stage {stage}"
        return Estimate.na(why, "e-"), Estimate.na(why, "DN")
    dn = Estimate(math.sqrt(v), se / (2 * math.sqrt(v)), "DN", f"sqrt(Ps) at stage {stage} ({which})")
    if ps.get("verdict") == VERDICT_UPPER:  # Ps a bound (a mask too short to see every defect): so is DSNU
        note = f"sqrt(Ps) at stage {stage} ({which}); {ps.get('note', '')}"
        dn = Estimate.limit(math.sqrt(v), "upper", "DN", note)
        if gain is None or not gain.available:
            return Estimate.na("no gain measured to turn DN into e-", "e-"), dn
        return Estimate.limit(dn.value / gain.value, "upper", "e-", note.replace("sqrt(Ps)", "sqrt(Ps) / K", 1)), dn
    if gain is None or not gain.available:
        return Estimate.na("no gain measured to turn DN into e-", "e-"), dn
    d = dn.value / gain.value
    gse = gain.se / gain.value if math.isfinite(gain.se) else 0.0
    return Estimate(d, d * math.hypot(se / (2 * v), gse), "e-",
                    f"sqrt(Ps) / {gain.note or 'K'} at stage {stage} ({which})"), dn


def _prnu(pg: dict | None, which: str, stage: str) -> Estimate:
    if not isinstance(pg, dict) or pg.get("value") is None:
        return Estimate.na(f"no pixel gain spread at stage {stage} (a dark stage: no light to spread)", "%")
    v, se = float(pg["value"]), pg.get("se")
    se = float(se) if se is not None else math.nan
    if v <= 0:
        return Estimate.na(f"pixel gain spread not above 0 at stage {stage}", "%")
    return Estimate(100 * math.sqrt(v), 100 * se / (2 * math.sqrt(v)), "%",
                    f"100 sqrt(Pg) at stage {stage} ({which})")


def lit_without_dark(scene: str | None, every: dict | None) -> bool:
    """A lit stack decomposed alone (no matched dark, so no stage gain G): its Ps holds the
    photo-response non-uniformity and its Pt the shot noise -- not a DSNU, not a read noise."""
    return scene == "flat" and not (every or {}).get("G")


def nonuniformity(masked: dict | None, every: dict | None, gain: Estimate | None, stage: str,
                  why_no_mask: str = NO_MASK, scene: str | None = None) -> dict[str, Estimate]:
    """DSNU/PRNU of one stage's components: ``masked`` (defect pixels left out; None when
    the scan had no mask: ``why_no_mask``) and ``every`` (all pixels). ``gain``: K (DN/e-),
    its note naming it ("K" or "stage gain G"). ``scene``: the stage's ("dark"/"flat")."""
    if lit_without_dark(scene, every):
        why = (f"stage {stage} is a lit stack without a matched dark: its pixel FPN holds the photo-response "
               "non-uniformity too, and it has no gain spread")
        units = {"dsnu_e": "e-", "dsnu_dn": "DN", "dsnu_all_e": "e-", "dsnu_all_dn": "DN", "prnu_pct": "%",
                 "prnu_all_pct": "%"}
        return {k: Estimate.na(why, u) for k, u in units.items()}
    out: dict[str, Estimate] = {}
    if masked:
        out["dsnu_e"], out["dsnu_dn"] = _dsnu(masked.get("Ps"), gain, "defect pixels excluded", stage)
    else:
        out["dsnu_e"], out["dsnu_dn"] = Estimate.na(why_no_mask, "e-"), Estimate.na(why_no_mask, "DN")
    out["dsnu_all_e"], out["dsnu_all_dn"] = _dsnu((every or {}).get("Ps"), gain, "all pixels", stage)
    out["prnu_pct"] = _prnu(masked.get("Pg"), "defect pixels excluded", stage) if masked else \
        Estimate.na(why_no_mask, "%")
    out["prnu_all_pct"] = _prnu((every or {}).get("Pg"), "all pixels", stage)
    return {k: out[k] for k in labels.HEADLINE_FIGURES if k in out}


def headline_gain(analyses: dict, components: dict | None = None) -> Estimate | None:
    """K of the run's PTC (note "K"), else the decomposed stage's own gain (note "stage gain G")."""
    k = _est((analyses.get("ptc") or {}).get("gain_dn_per_e"))
    if k is not None and k.available:
        return Estimate(k.value, k.se, "DN/e-", "K")
    g = _est((components or {}).get("G"))
    if g is not None and g.available:
        return Estimate(g.value, g.se, "DN/e-", "stage gain G")
    return None


def decomposition_nonuniformity(analyses: dict) -> dict[str, Estimate]:
    """The headline DSNU/PRNU of the scan's decomposition (``scan_results["decomposition"]``)."""
    d = analyses.get("decomposition")
    if not isinstance(d, dict) or not isinstance(d.get("components"), dict):
        return {}
    if "components_unmasked" in d:
        masked, every, why = d["components"], d["components_unmasked"], NO_MASK
    else:
        masked, every = None, d["components"]
        why = d.get("mask_note") or f"{NO_MASK} ({labels.MASK_POLICY})"
    return nonuniformity(masked, every, headline_gain(analyses, every), d["stage"], why, d.get("scene"))


def snr_max_emva(ptc: dict) -> Estimate:
    """SNR max by EMVA 1288 4.0 Eq. 55: sqrt(saturation capacity)."""
    s = _est(ptc.get("saturation_capacity_e"))
    if s is None or not s.available or s.value <= 0:
        return Estimate.na("no saturation capacity measured", "")
    se = s.se / (2 * math.sqrt(s.value)) if math.isfinite(s.se) else math.nan
    return Estimate(math.sqrt(s.value), se, "", "sqrt(saturation capacity)")


def headline(analyses: dict) -> list[tuple[str, str, dict | None]]:
    """``(key, name, estimate dict or None)`` of every headline figure the results hold, in
    print order (``labels.PTC_FIGURES`` then ``labels.HEADLINE_FIGURES``)."""
    out: list[tuple[str, str, dict | None]] = []
    p = analyses.get("ptc")
    if isinstance(p, dict) and "gain_dn_per_e" in p:
        out += [(k, name, p.get(k)) for k, name in labels.PTC_FIGURES]
        out.append(("snr_max_emva", labels.figure_name("snr_max_emva"), snr_max_emva(p).to_dict()))
        out.append(("snr_max", labels.figure_name("snr_max"), p["snr_max"] if isinstance(p.get("snr_max"), dict) else
                    Estimate.na("not in these results (stored before ARES kept it: the report's key figures "
                                "recompute it from the curve)", "").to_dict()))
    for k, e in decomposition_nonuniformity(analyses).items():
        out.append((k, labels.figure_name(k), e.to_dict()))
    return out


def same_point(ptc: dict) -> str | None:
    """One sentence when the saturation capacity and the PTC turnoff are one level."""
    s, t = _est(ptc.get("saturation_capacity_e")), _est(ptc.get("turnoff_e"))
    if s is None or t is None or not (s.available and t.available) or s.value != t.value:
        return None
    return (f"saturation capacity and PTC turnoff are one point (the level at "
            f"{_est(ptc.get('turnoff_dn')).value:.5g} DN): the SEs differ by definition -- the saturation "
            f"capacity's from the signal's noise, the turnoff's from the level spacing")


def full_well_note(ptc: dict) -> str | None:
    """When the full well's plateau is the ADC's maximum code, not the pixel's well: say so."""
    fw = ptc.get("full_well_definitions") or {}
    if isinstance(fw.get("plateau"), dict) and fw["plateau"].get("value") is None and \
            "ADC" in str(fw["plateau"].get("note", "")):
        return ("full well (charge) is where the ADC clips (its maximum code comes before the pixel's well "
                "fills): not the pixel's well")
    code, plateau = _est(fw.get("max_code")), _est(fw.get("plateau"))
    if code is not None and plateau is not None and code.available and plateau.available and \
            abs(code.value - plateau.value) <= max(3 * (plateau.se if math.isfinite(plateau.se) else 0.0),
                                                   1e-3 * plateau.value):
        return "full well (charge) is where the ADC clips (its maximum code), not the pixel's well"
    return None
