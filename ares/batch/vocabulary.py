"""One vocabulary of quantities for every kind of lot item.

A run directory reports the photon-transfer names of ``ares.labels.PTC_FIGURES`` /
``ares.protocol.quantities.PRODUCES["ptc"]``; an EMVA 1288 Release 4.0 descriptor reports the
symbols of its Table 2 (``K``, ``sigma_d``, ...). The lot table, the limits and the results
database use the canonical (photon-transfer) name wherever the two measure the same thing in
the same unit, so a limit on ``gain_dn_per_e`` -- or on ``K`` -- judges both kinds alike:

- ``K`` (EMVA 1288 4.0, Eq. 11: system gain, DN/e-) is ``gain_dn_per_e``; ``K_inv`` is ``gain_e_per_dn``;
- ``sigma_d`` (Eq. 13, temporal dark noise in e-) is ``read_noise_e``; ``sigma_y_dark`` (DN) is
  ``read_noise_dn``;
- ``mu_e_sat`` (saturation capacity, e-) is ``saturation_capacity_e``; ``DR_db`` is ``dynamic_range_db``.

Every other EMVA symbol keeps its name (it is then canonical: no other item kind has it).
"""

from __future__ import annotations

# EMVA 1288 4.0 symbol -> (canonical name, its unit)
EMVA_TO_CANONICAL = {
    "K": ("gain_dn_per_e", "DN/e-"), "K_inv": ("gain_e_per_dn", "e-/DN"),
    "sigma_d": ("read_noise_e", "e-"), "sigma_y_dark": ("read_noise_dn", "DN"),
    "mu_e_sat": ("saturation_capacity_e", "e-"), "DR_db": ("dynamic_range_db", "dB"),
}
ALIASES = {k: v[0] for k, v in EMVA_TO_CANONICAL.items()}


def canonical(name: str) -> str:
    """The canonical name of a quantity (a dotted path keeps its prefix)."""
    head, _, last = name.rpartition(".")
    c = ALIASES.get(last, last)
    return f"{head}.{c}" if head else c


def canonical_figures(figures: dict) -> dict:
    """``figures`` ({name: {label, value, se, unit, ...}}) renamed to the canonical names; the
    original name is kept as ``symbol``. A canonical name already present wins (never two)."""
    out = {}
    for k, f in figures.items():
        c = canonical(k)
        if c != k:
            if c in figures:
                continue
            f = {**f, "symbol": k}
        out[c] = f
    return out


def quantity_label(key: str) -> str:
    """What a lot surface (lot PDF, certificate, trend) calls the quantity ``key`` -- the label
    the scan surfaces give it (``ares.labels``, the report's key figures, the EMVA 1288
    symbols), from the key alone (the results database keeps no label): a photon-transfer
    figure its ``labels.FIGURES`` name, a noise component its symbol and meaning ("o: offset",
    as the components table), an EMVA 1288 4.0 symbol "EMVA 1288 4.0 <symbol>", an analysis's
    figure ``page_tables.analysis_label``'s; an unknown key itself."""
    from ares import labels

    if key in labels.FIGURES:
        return labels.figure_name(key)
    if key in labels.COMPONENTS:
        return f"{key}: {labels.COMPONENTS[key]}"
    if key == "snr_max_db":
        return labels.figure_name("snr_max")
    base, at, rest = key.partition("@")
    if at and base in labels.BY_ANALOG_GAIN:
        return f"{labels.BY_ANALOG_GAIN[base]} at analog gain {rest}"
    if key.startswith("dark_current") and key.endswith(("_dn_per_s", "_e_per_s")) and "." not in key:
        t = key.removeprefix("dark_current").removesuffix("_dn_per_s").removesuffix("_e_per_s").lstrip("@")
        return "dark current" + (f" at {t.removesuffix('C')} C" if t else "")
    head, dot, leaf = key.partition(".")
    if dot and head == "full_well_e":
        from ares.report.tables import FULL_WELL_LABELS

        return FULL_WELL_LABELS.get(leaf, f"full well ({leaf})")
    if dot and head == "defects":
        return labels.DEFECTIVE_PIXELS + ("" if leaf == "total" else f": {leaf}")
    if key == "decomposition.masked_pixels":
        return labels.MASKED_PIXELS
    if dot:
        from ares.report.page_tables import analysis_label

        return analysis_label(head, leaf)
    from ares.analysis.emva.sheet import SYMBOLS

    return f"EMVA 1288 4.0 {SYMBOLS[key]}" if key in SYMBOLS else key


def quantity_heading(key: str, unit: str = "") -> str:
    """``quantity_label`` with its unit, "label [unit]" (a unitless quantity: the label)."""
    label = quantity_label(key)
    return f"{label} [{unit}]" if unit and unit != "1" else label
