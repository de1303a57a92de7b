"""What a reader sees a quantity called: one table for the CLI, the CSV headers and label
columns, the PDF, the JSON notes and the GUI (no imports: every layer may use it).

``COMPONENTS``: the 13 components of the noise model (DESIGN.md) and the extras, symbol ->
meaning; ``component_label`` says what a symbol means in a given part of a stage result.
``PTC_FIGURES``: the photon-transfer headline figures, result key -> label, in the order
they are printed (the terminal's summary and the top of the window's Information tab, then
``HEADLINE_COMPONENTS``). Units travel with the values (``Estimate.unit``), not here.
"""

from __future__ import annotations

COMPONENTS = {
    "o": "offset", "Cs": "column FPN", "Ct": "column temporal", "Rs": "row FPN", "Rt": "row temporal",
    "Ps": "pixel FPN (DSNU)", "Pt": "pixel temporal (read)", "G": "conversion gain", "Cg": "column gain NU",
    "Rg": "row gain NU", "Pg": "pixel gain NU (PRNU)", "q": "photo-charge", "delta": "shot noise",
    "frame_global": "frame-global temporal offset", "signal": "signal (flat - dark)",
    "poisson_ratio": "Poisson check: delta / q (1 when the given gain is right)",
}

PTC_FIGURES = (
    ("conversion_gain_uv_per_e", "conversion gain"), ("gain_dn_per_e", "system gain K"), ("gain_e_per_dn", "1/K"),
    ("read_noise_e", "read noise sigma_d (no quant.)"),
    ("read_noise_dn", "dark noise sigma_y.dark (incl. quant.)"), ("full_well_e", "full well (charge)"),
    ("saturation_capacity_e", "saturation capacity"), ("turnoff_dn", "PTC turnoff"),
    ("turnoff_e", "PTC turnoff (charge)"), ("dynamic_range_db", "dynamic range"),
)
PTC_LABELS = dict(PTC_FIGURES)
# The decomposition's headline components (DSNU, PRNU: the engine's order), printed by the
# terminal and shown at the top of the window's Information tab after the PTC figures.
HEADLINE_COMPONENTS = ("Ps", "Pg")


def component_label(c: str, part: str = "components") -> str:
    """What a component means in a stage's ``part``: in the ANOVA of the flat stack itself
    Pt holds the shot noise too; in a flat stage's ``components`` the offset/noise terms
    come from its matched dark stack."""
    if c == "Pt" and part == "flat_anova":
        return "pixel temporal (read + shot)"
    if c == "delta":
        return "shot-noise variance (= q when G is estimated from this level)"
    return COMPONENTS.get(c, "")


# ------------------------------------------------------------------ units in names
# One naming scheme for every table column and HDF5 dataset: the quantity, then its unit as a
# suffix (mean_dn, var_dn2, exposure_s, G_dn_per_e, light_photons_per_pixel_s); a quantity
# without a unit (a count, a ratio of like quantities) has none. HDF5 datasets carry the unit
# as written (attribute "unit") as well.
_SUFFIX = {"DN": "dn", "DN^2": "dn2", "DN/e-": "dn_per_e", "e-/DN": "e_per_dn", "e-": "e", "e-^2": "e2",
           "1": "rel_var", "%": "pct", "dB": "db", "s": "s", "C": "c", "x": "x", "e-/s": "e_per_s",
           "DN/s": "dn_per_s", "uV/e-": "uv_per_e", "LSB": "lsb", "nm": "nm", "A": "a", "W": "w", "A/W": "a_per_w",
           "photons": "photons"}
_UNIT = {v: k for k, v in _SUFFIX.items()}


def unit_suffix(unit: str) -> str:
    """``DN^2`` -> ``dn2``, ``photons/pixel/s`` -> ``photons_per_pixel_s``, ``V`` -> ``v``."""
    if unit in _SUFFIX:
        return _SUFFIX[unit]
    out = unit.lower().replace("^2", "2").replace("/", "_per_").replace("µ", "u").replace("°", "")
    return "".join(ch if ch.isalnum() else "_" for ch in out).strip("_")


def with_unit(name: str, unit: str) -> str:
    """A column name with its unit: ``with_unit("Ps", "DN^2")`` -> ``Ps_dn2``."""
    suffix = unit_suffix(unit) if unit else ""
    return f"{name}_{suffix}" if suffix and not name.endswith("_" + suffix) else name


# numeric columns that are counts, indices or fractions (unit "1"), and the analog gain factor
COUNT_COLUMNS = {"index", "stage_index", "code", "transition", "frames", "dark_frames", "n_pixels", "n_frames", "dark_n_frames",
                 "frac_at_max", "frac_at_min", "dark_frac_at_max", "dark_frac_at_min"}


def unit_of_column(name: str) -> str:
    """The unit a column name carries by the scheme above ("" when it names none)."""
    if name in COUNT_COLUMNS:
        return "1"
    if name == "analog_gain":
        return "x"
    if name == "seconds":
        return "s"
    for suffix in sorted(_UNIT, key=len, reverse=True):
        if name.endswith("_" + suffix):
            return _UNIT[suffix]
    if name.startswith("photons_per_pixel"):
        return "photons/pixel"
    return ""


# the unit of each per-stage array in a run directory's HDF5 files (attribute "unit")
ARRAY_UNITS = {"mean": "DN", "variance": "DN^2", "frame_means": "DN", "dark_mean": "DN", "frames": "DN",
               "dark": "DN", "defect_mask": "1 (0: good, else a defect class code)",
               "frame_counter": "1 (the device's frame counter, else the frame source's count)",
               "frame_timestamp": "s (host time at arrival; the simulator's model clock)",
               "frame_temperature": "C (the device's, as it reports it)",
               "frame_device_timestamp": "s (the device's own clock, GenTL timestamp_ns)",
               # the dark stage's RTS candidates and their time series (ares.scan.defect_mask)
               "rts_rows": "1 (pixel row index)", "rts_cols": "1 (pixel column index)",
               "rts_series": "DN (one row per frame, one column per candidate pixel)"}
ARRAY_UNITS.update({f"dark_{k}": ARRAY_UNITS[k] for k in ("frame_counter", "frame_timestamp", "frame_temperature",
                                                           "frame_device_timestamp")})


def array_unit(name: str) -> str:
    if name.startswith("link_"):  # a stage's link statistics (ares.hardware.link_stats)
        return "bytes" if name.endswith("_bytes") else "1 (count during the stage)"
    return "counts per code" if name.startswith("hist_") else ARRAY_UNITS.get(name, "")
