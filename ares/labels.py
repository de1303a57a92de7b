"""What a reader sees a quantity called: one table for the CLI, the CSV headers and label
columns, the PDF, the JSON notes and the GUI (no imports: every layer may use it).

``COMPONENTS``: the 13 components of the noise model (DESIGN.md) and the extras, symbol ->
meaning; ``component_label`` says what a symbol means in a given part of a stage result.
``PTC_FIGURES``: the photon-transfer headline figures, result key -> label, in the order
they are printed. Units travel with the values (``Estimate.unit``), not here.
"""

from __future__ import annotations

COMPONENTS = {
    "o": "offset", "Cs": "column FPN", "Ct": "column temporal", "Rs": "row FPN", "Rt": "row temporal",
    "Ps": "pixel FPN (DSNU)", "Pt": "pixel temporal (read)", "G": "conversion gain", "Cg": "column gain NU",
    "Rg": "row gain NU", "Pg": "pixel gain NU (PRNU)", "q": "photo-charge", "delta": "shot noise",
    "frame_global": "frame-global temporal offset", "signal": "signal (flat - dark)",
}

PTC_FIGURES = (
    ("conversion_gain_uv_per_e", "conversion gain"), ("gain_dn_per_e", "system gain K"), ("gain_e_per_dn", "1/K"),
    ("read_noise_e", "read noise sigma_d (no quant.)"),
    ("read_noise_dn", "dark noise sigma_y.dark (incl. quant.)"), ("full_well_e", "full well (charge)"),
    ("saturation_capacity_e", "saturation capacity"), ("turnoff_dn", "PTC turnoff"),
    ("turnoff_e", "PTC turnoff (charge)"), ("dynamic_range_db", "dynamic range"),
)
PTC_LABELS = dict(PTC_FIGURES)


def component_label(c: str, part: str = "components") -> str:
    """What a component means in a stage's ``part``: in the ANOVA of the flat stack itself
    Pt holds the shot noise too; in a flat stage's ``components`` the offset/noise terms
    come from its matched dark stack."""
    if c == "Pt" and part == "flat_anova":
        return "pixel temporal (read + shot)"
    if c == "delta":
        return "shot-noise variance (= q when G is estimated from this level)"
    return COMPONENTS.get(c, "")
