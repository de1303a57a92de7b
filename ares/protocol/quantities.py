"""What each scan-level analysis produces: the names a ``<limit quantity=...>`` may use.

A limit names a quantity by its key (``read_noise_e``) or by its dotted path in the run's
``scan_results.json`` (``ptc.read_noise_e``, ``defects.counts.hot``); ``ares validate``,
``ares run --dry-run`` and ``ares run`` refuse a name that none of the scan's analyses
produces, so a misspelt limit fails before the run, not after it. A test runs every
shipped scan and checks each analysis's output against this table.
"""

from __future__ import annotations

PRODUCES: dict[str, frozenset[str]] = {
    "ptc": frozenset({
        "gain_dn_per_e", "gain_e_per_dn", "gain_line_dn_per_e", "gain_origin_dn_per_e", "gain_astier_dn_per_e", "conversion_gain_uv_per_e", "read_noise_e",
        "read_noise_dn", "full_well_e", "saturation_capacity_e", "dynamic_range_db", "sensitivity_threshold_e",
        "linearity_error_pct", "mean_rel_dev", "qe", "snr_max", "a00_per_e", "ptc_turnoff", "plateau", "bracket",
        "linearity_1pct", "max_variance", "max_code", "saturation_capacity", "low_e", "high_e",
        "defect_pixels_excluded", "line_chi2_red", "line_p", "astier_chi2_red", "astier_p", "curvature_f_test_p",
        "turnoff_dn", "turnoff_e", "emva4_saturation", "lsst_turnoff"}),
    "decomposition": frozenset({
        "G", "Pg", "Cg", "Rg", "Ps", "Cs", "Rs", "Pt", "Ct", "Rt", "o", "q", "delta", "frame_global",
        "masked_pixels"}),
    "dark_current": frozenset({"rate_dn_per_s", "rate_e_per_s", "rate_from_variance_e_per_s", "offset_dn",
                               "dsnu_dn_per_s", "dsnu_e_per_s"}),
    "temperature": frozenset({"doubling_temperature_c", "rate_at_ref_dn_per_s", "rate_at_ref_e_per_s"}),
    "gain_split": frozenset({"pixel_noise_e", "chain_noise_dn", "crossover_gain_dn_per_e", "chi2_red"}),
    "lag": frozenset({"lag_pct", "bright_signal_dn"}),
    "defects": frozenset({"hot", "warm", "dead", "stuck", "low_response", "high_response", "bad_rows",
                          "bad_columns", "clusters", "unclassified", "total"}),
    "adc_linearity": frozenset({"dnl_max_lsb", "dnl_min_lsb", "inl_max_lsb", "inl_min_lsb", "missing_codes"}),
    "emva1288": frozenset({"K", "QE", "sigma_y_dark", "u_I_mean", "u_I_var", "u_e_sat", "DR", "SNR_max",
                           "DSNU1288", "PRNU1288", "LE_min", "LE_max"}),
    # EMVA 1288 Release 4.0 Linear (Table 2 and ares.analysis.emva.sheet.EXTRA) and General
    "emva4": frozenset({"QE", "K", "K_inv", "sigma_y_dark", "sigma_d", "SNR_max", "SNR_max_db", "SNR_max_inv",
                        "mu_e_min", "mu_e_min_area", "mu_e_sat", "mu_e_sat_area", "DR", "DR_db", "DSNU1288",
                        "DSNU1288_col", "DSNU1288_row", "DSNU1288_pix", "PRNU1288", "PRNU1288_col", "PRNU1288_row",
                        "PRNU1288_pix", "LE", "mu_I_mean", "mu_I_var", "R", "mu_p_min", "mu_p_sat", "mu_y_sat",
                        "DSNU1288_DN", "sigma_y_stack_dark", "sigma_y_stack_50", "R_d",
                        "mu_p_min_area", "mu_p_sat_area"}),  # (General Table 2, photons per µm²)
    "mtf": frozenset({"mtf50_cy_per_px", "mtf_at_nyquist", "angle_deg", "edge_step_snr", "nyquist_cy_per_px",
                      "frames"}),
    "photon_counting": frozenset({"K", "read_noise_e", "mean_e", "offset_dn", "chi2_ndf"}),
    "spectral_qe": frozenset({"qe", "mu_p", "net_signal_dn", "gain_dn_per_e", "wavelength_nm", "bandwidth_nm",
                              "u_calibration", "u_gain", "u_signal", "u_photodiode", "area_mm2", "pixel_pitch_um",
                              "range_nm"}),
    "dark_temperature": frozenset({"rates", "doubling_c", "rate_at_ref", "activation_ev", "ln_prefactor", "chi2_dof",
                                   "ln_rate_scatter",
                                   "pixels", "median_activation_ev", "activation_spread_ev", "activation_fit_noise_ev",
                                   "median_doubling_c", "field_enhanced", "depletion", "diffusion",
                                   "hot_by_activation", "meyer_neldel_ev", "isokinetic_k", "naive_ev", "pixels_mn", "artefact_ev", "rates_se", "pixels_left_out",
                                   "t_mean_k"}),
    "rtn": frozenset({"rtn_pixels", "rtn_fraction", "temporal_noise_dn", "temporal_noise_without_rtn_dn",
                      "temporal_noise_increase_pct", "median_amplitude_dn", "frames", "candidates", "three_level",
                      "pixels", "1x", "2x", "3x", "5x", "within_level_sigma_dn", "frame_period_s", "dwell_se_p10_pct",
                      "dwell_se_median_pct", "dwell_se_p90_pct", "dwell_resolved", "dwell_frames_needed"}),
    "fe55": frozenset({"kalpha_dn", "kalpha_sigma_dn", "kbeta_ratio", "gain_e_per_dn", "electrons_per_kalpha",
                       "pair_energy_ev", "gain_systematic_rel", "temperature_c", "line_ev", "chi2_dof", "events_in_fit",
                       "events_total", "bin_dn", "single", "split", "threshold_dn", "split_dn", "noise_dn", "frames",
                       "transfer_per_row", "transfer_per_col"}),
}


def producible(analyses) -> dict[str, str]:
    """Quantity name -> the analysis producing it, for the analyses a scan lists."""
    return {q: a for a in analyses for q in sorted(PRODUCES.get(a, ()))}


def unknown_limit(quantity: str, analyses) -> str | None:
    """None when some listed analysis produces ``quantity`` (a key or a dotted path ending
    in one), else one sentence why not."""
    names = producible(analyses)
    parts = quantity.split(".")
    if parts[-1] in names and (len(parts) == 1 or parts[-1] in PRODUCES.get(parts[0], ())):
        return None
    if parts[-1] in {q for qs in PRODUCES.values() for q in qs}:
        owner = ", ".join(a for a, qs in PRODUCES.items() if parts[-1] in qs)
        return (f"limit on '{quantity}': no analysis of this scan produces it (add <analysis name=\"{owner}\"/>)"
                if len(parts) == 1 or parts[0] not in analyses else
                f"limit on '{quantity}': analysis '{parts[0]}' does not produce '{parts[-1]}' ({owner} does)")
    import difflib

    close = difflib.get_close_matches(parts[-1], list(names), n=3)
    hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else \
        (f"; the scan's analyses produce: {', '.join(names)}" if names else "; the scan lists no analyses")
    return f"limit on '{quantity}': unknown quantity{hint}"
