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
