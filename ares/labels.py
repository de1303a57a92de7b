"""What a reader sees a quantity called: one table for the CLI, the CSV headers and label
columns, the PDF, the JSON notes and the GUI (no imports: every layer may use it).

``COMPONENTS``: the 13 components of the noise model (DESIGN.md) and the extras, symbol ->
meaning; ``component_label`` says what a symbol means in a given part of a stage result.
``FIGURES``: every headline figure's one name and one-line definition; ``PTC_FIGURES`` and
``HEADLINE_FIGURES`` the order they are printed in (the terminal's summary, --json and the
top of the window's Information tab). Units travel with the values (``Estimate.unit``).
docs/quantities.md lists every quantity with the surfaces that show it.
"""

from __future__ import annotations

# Every variance is named a variance; the gain spreads (Cg, Rg, Pg) are relative variances
# (unit "1") in JSON, CSV and HDF5 and shown as % rms on the terminal, the PDF and the window.
# "DSNU" and "PRNU" name only the rms figures of ``FIGURES`` below, never a component.
COMPONENTS = {
    "o": "offset", "Cs": "column FPN variance", "Ct": "column temporal variance", "Rs": "row FPN variance",
    "Rt": "row temporal variance", "Ps": "pixel offset FPN variance", "Pt": "pixel temporal variance (read)",
    "G": "stage gain G (flat - dark)", "Cg": "column gain NU", "Rg": "row gain NU", "Pg": "pixel gain NU",
    "q": "photo-charge", "delta": "shot-noise variance",
    "frame_global": "frame-global temporal variance", "signal": "signal (flat - dark)",
    "poisson_ratio": "Poisson check: delta / q (1 when the given gain is right)",
}

# One name and one definition per figure (result key -> (name, definition)); the unit travels
# with the value. Figures that differ by definition have names of their own: defects excluded
# or not, with or without quantization noise, the standard's or ARES's.
FIGURES = {
    "conversion_gain_uv_per_e": ("conversion gain (charge to voltage)",
                                 "K x ADC step / analog gain: volts at the sense node per electron"),
    "gain_dn_per_e": ("system gain K", "the photon-transfer slope of the whole chain, DN per electron "
                                       "(EMVA 1288 4.0 Linear Eq. 9); the stage gain G is one stage's"),
    "gain_e_per_dn": ("inverse system gain 1/K", "electrons per DN"),
    "read_noise_e": ("read noise sigma_d (no quant.)", "dark temporal noise in e-, quantization noise "
                                                       "removed (EMVA 1288 4.0 Linear Eq. 53)"),
    "read_noise_dn": ("dark noise sigma_y.dark (incl. quant.)", "dark temporal noise at the output in DN, "
                                                                "quantization noise included"),
    "full_well_e": ("full well (charge)", "median signal of the fully clipped levels / K: where the output "
                                          "stops growing (the pixel's well, or the ADC's maximum code when "
                                          "that comes first: then said so)"),
    "saturation_capacity_e": ("saturation capacity", "EMVA 1288 4.0: the last level with <= 0.2 % of its "
                                                     "samples clipped, in e-"),
    "turnoff_dn": ("PTC turnoff", "the last level the curve follows before it departs (SE: level spacing)"),
    "turnoff_e": ("PTC turnoff (charge)", "the PTC turnoff / K"),
    "dynamic_range_db": ("dynamic range", "saturation capacity / absolute sensitivity threshold "
                                          "(EMVA 1288 4.0 Eq. 28)"),
    "qe": ("quantum efficiency", "R / K (EMVA 1288 4.0 Linear Eq. 52)"),
    "linearity_error_pct": ("linearity error", "max |relative deviation| from a line fitted on 5-95 % "
                                               "of saturation"),
    "snr_max_emva": ("SNR max (sqrt of saturation capacity)", "sqrt(saturation capacity), the form of EMVA 1288 4.0 "
                                                              "Eq. 55 on the photon-transfer saturation capacity (an "
                                                              "EMVA datasheet's SNR_max uses its own mu_e.sat)"),
    "snr_max": ("SNR max (measured)", "the largest measured signal / temporal noise on the curve (SE from the "
                                      "variance's chi-square scatter; at most sqrt of the full well)"),
    "dsnu_e": ("DSNU (defects excluded)", "pixel offset FPN rms sqrt(Ps) / K of the decomposed stage, "
                                          "defect pixels left out"),
    "dsnu_dn": ("DSNU (defects excluded)", "pixel offset FPN rms sqrt(Ps), defect pixels left out"),
    "dsnu_all_e": ("DSNU (all pixels)", "pixel offset FPN rms sqrt(Ps) / K of the decomposed stage, "
                                        "every pixel"),
    "dsnu_all_dn": ("DSNU (all pixels)", "pixel offset FPN rms sqrt(Ps), every pixel"),
    "prnu_pct": ("PRNU (defects excluded)", "pixel gain spread rms 100 sqrt(Pg) of the decomposed stage, "
                                            "defect pixels left out"),
    "prnu_all_pct": ("PRNU (all pixels)", "pixel gain spread rms 100 sqrt(Pg), every pixel"),
    "noise_model.prnu_pct": ("PRNU (total-noise model)", "the PRNU term of the total-noise model fitted to "
                                                         "the curve; illumination non-uniformity included"),
    "noise_model.sensor_noise_e": ("sensor noise (total-noise model)", "the signal-independent noise term of the "
                                                                       "total-noise model fitted to the curve, in e-"),
    "gain_origin_dn_per_e": ("K, EMVA 1288 origin fit", "the photon-transfer slope by the origin fit up to 70 % of "
                                                        "saturation"),
    "gain_astier_dn_per_e": ("K, Astier 2019 fit", "the photon-transfer gain of the Astier 2019 exponential model"),
}
# a scan with several analog gains: these figures again per gain, "<name> at analog gain <g>"
BY_ANALOG_GAIN = {"gain_dn_per_e": "system gain K", "read_noise_e": "read noise", "full_well_e": "full well"}


# a scan-level analysis whose figures follow one release of a standard: said wherever they are
ANALYSIS_TITLES = {"emva1288": "EMVA 1288 Release 3.0 definitions", "emva4": "EMVA 1288 Release 4.0 Linear",
                   "emva4.general": "EMVA 1288 Release 4.0 General"}


def analysis_title(name: str) -> str:
    """``emva1288`` -> ``emva1288 (EMVA 1288 Release 3.0 definitions)``; others as they are."""
    return f"{name.rsplit('.', 1)[-1]} ({ANALYSIS_TITLES[name]})" if name in ANALYSIS_TITLES else name


def figure_name(key: str) -> str:
    return FIGURES[key][0]


PTC_FIGURES = tuple((k, FIGURES[k][0]) for k in (
    "conversion_gain_uv_per_e", "gain_dn_per_e", "gain_e_per_dn", "read_noise_e", "read_noise_dn", "full_well_e",
    "saturation_capacity_e", "turnoff_dn", "turnoff_e", "dynamic_range_db", "qe", "linearity_error_pct"))
PTC_LABELS = dict(PTC_FIGURES)
# The headline figures after the photon-transfer ones, on the terminal, in --json and at the
# top of the window's Information tab (ares.report.headline computes them from the results):
# the two SNR max (sqrt of the saturation capacity; measured), then DSNU and PRNU with defects excluded and with every pixel.
SNR_FIGURES = ("snr_max_emva", "snr_max")  # printed with the photon-transfer figures
HEADLINE_FIGURES = ("snr_max_emva", "snr_max", "dsnu_e", "dsnu_dn", "dsnu_all_e", "dsnu_all_dn", "prnu_pct", "prnu_all_pct")
# One mask policy for every scan kind (ares.scan.defect_mask): a scan whose stages include a
# dark and a flat stack finds its defect pixels and leaves them out of every decomposition;
# a scan without that pair has no mask, and its "defects excluded" figures say so.
MASK_POLICY = ("defect pixels are left out when the scan has a dark and a flat stack to find them; "
               "otherwise the 'defects excluded' figures are not available and the 'all pixels' ones stand")
# Two defect sets are named apart: the mask the decomposition leaves out (found early in
# the scan, by the runner) and the defect analysis's classified pixels (its own classes and
# thresholds).
MASKED_PIXELS = "defect pixels masked out of the decomposition"
DEFECTIVE_PIXELS = "defective pixels (defect analysis)"
DEFECT_COUNT_UNITS = {"bad_columns": "columns", "bad_rows": "rows", "clusters": "clusters"}  # else "pixels"


def defect_count_unit(cls: str) -> str:
    """The unit of a defect class's count (every surface: a count with its unit)."""
    return DEFECT_COUNT_UNITS.get(cls, "pixels")


def component_label(c: str, part: str = "components") -> str:
    """What a component means in a stage's ``part``: in the ANOVA of the flat stack itself
    Pt holds the shot noise too; in a flat stage's ``components`` the offset/noise terms
    come from its matched dark stack."""
    if c == "Pt" and part == "flat_anova":
        return "pixel temporal variance (read + shot)"
    if c == "Ps" and part == "flat_anova":
        return "pixel FPN variance (offset + response)"
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
           "photons": "photons", "photons/pixel/s": "photons_per_pixel_per_s", "photons/pixel": "photons_per_pixel",
           "V": "v"}
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
COUNT_COLUMNS = {"index", "stage_index", "masked_pixels", "code", "transition", "frames", "dark_frames", "n_pixels", "n_frames", "dark_n_frames",
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
               "frame_device_timestamp": "s (the device's own clock: GenTL timestamp_ns, the ares40 USB header)",
               # the dark stage's RTS candidates and their time series (ares.scan.defect_mask)
               "rts_rows": "1 (pixel row index)", "rts_cols": "1 (pixel column index)",
               "rts_series": "DN (one row per frame, one column per candidate pixel)"}
ARRAY_UNITS.update({f"dark_{k}": ARRAY_UNITS[k] for k in ("frame_counter", "frame_timestamp", "frame_temperature",
                                                           "frame_device_timestamp")})


def array_unit(name: str) -> str:
    if name.startswith("link_"):  # a stage's link statistics (ares.hardware.link_stats)
        return "bytes" if name.endswith("_bytes") else "1 (count during the stage)"
    if name.startswith("histgroups_"):  # an ADC ramp's sub-histograms (ares.results.adc)
        return "counts per code (one row per sub-histogram: frame i in row i mod rows)"
    return "counts per code" if name.startswith("hist_") else ARRAY_UNITS.get(name, "")
