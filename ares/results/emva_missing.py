"""What an EMVA 1288 data set still lacks: ``ares emva DESCRIPTOR --missing``.

Read from the descriptor alone (no image is decoded): for each release, which figures the
data set supports and which steps a full datasheet still needs -- photon-transfer steps,
dark images at every exposure, exposure times for the dark current, the averaged stacks and
their length, photon counts, the pixel area. The requirements are those of EMVA 1288 4.0
Linear (each cited where it is checked); Release 3.x evaluates the same records (the
reference implementation's descriptor convention) with the looser minimums it accepts.
Whether the series reaches saturation, and whether the bright stack lies near 50 % of it,
needs the images: ``ares emva`` says so when it analyses them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

MIN_STEPS = 50  # Linear Section 6.5, "Distribution of radiant exposure values" (9 for production)
MIN_STEPS_PRODUCTION = 9
MIN_DARK_EXPOSURES_40 = 6  # Linear Section 7.1: at least six equally spaced exposure times
MIN_DARK_EXPOSURES_3X = 3  # Release 3.x dark current: a line through more than two exposures
MIN_STACK_40 = 100  # Linear Section 8: "averaging over L = 100 - 500 images is required"


@dataclass
class Coverage:
    release: str
    supported: list[str] = field(default_factory=list)
    missing: list[tuple[str, str]] = field(default_factory=list)  # (figures, what the data set needs)


def _figures(release: str) -> dict[str, list[str]]:
    """The figures of a release grouped by what they need."""
    if release.startswith("3"):
        return {"photon transfer": ["K", "sigma_y_dark", "LE_min", "LE_max"],
                "photon counts": ["R", "QE", "u_p_min", "u_e_min", "u_p_sat", "u_e_sat", "SNR_max", "DR"],
                "pixel area": ["u_p_min_area", "u_e_min_area", "u_p_sat_area", "u_e_sat_area"],
                "dark current": ["u_I_mean", "u_I_var"],
                "stacks": ["DSNU1288", "PRNU1288", "histograms (defect pixels)"]}
    if release == "4.0 General":
        return {"photon transfer": ["sigma_y_dark", "LE (if linear)"],
                "photon counts": ["sigma_d", "SNR_max", "mu_p_min", "mu_p_sat", "DR", "1/SNR_max"],
                "pixel area": ["mu_p_min_area", "mu_p_sat_area"],
                "dark current": ["mu_I_mean", "mu_I_var"],
                "stacks": ["DSNU1288 (.row/.col/.pix)", "PRNU1288 (.row/.col/.pix)"]}
    return {"photon transfer": ["K", "1/K", "sigma_y_dark", "LE"],
            "photon counts": ["R", "QE", "sigma_d", "SNR_max", "mu_e_min", "mu_p_min", "mu_e_sat", "mu_p_sat", "DR",
                              "1/SNR_max"],
            "pixel area": ["mu_e_min_area", "mu_e_sat_area"],
            "dark current": ["mu_I_mean", "mu_I_var"],
            "stacks": ["DSNU1288 (.row/.col/.pix)", "PRNU1288 (.row/.col/.pix)", "spectrograms, profiles, histograms"]}


def coverage(desc, pixel_area_um2: float | None = None) -> list[Coverage]:
    """Per release (3.0/3.1, 4.0 Linear, 4.0 General): the figures the descriptor's records
    support and, for the others, what is missing."""
    tb = desc.temporal_bright
    darks = {round(lv.exposure_ns, 3) for lv in desc.temporal_dark}
    no_dark = sorted({lv.exposure_ns for lv in tb if round(lv.exposure_ns, 3) not in darks})
    exposures = sorted({lv.exposure_ns for lv in tb})
    photons_known = bool(tb) and all(lv.photons > 0 for lv in tb)
    sb, sd = desc.spatial_bright, desc.spatial_dark
    stack_dark = [lv for lv in sd if sb and abs(lv.exposure_ns - sb[0].exposure_ns) <= 1e-9 * sb[0].exposure_ns]
    area = pixel_area_um2 or getattr(desc, "pixel_area_um2", None)
    out = []
    for release in ("3.0 / 3.1", "4.0 Linear", "4.0 General"):
        is40 = release.startswith("4.0")
        cov = Coverage(release)
        need: dict[str, str] = {}
        n = len(tb)
        min_steps = MIN_STEPS if is40 else 3
        if n < 3 or no_dark:
            why = []
            if n < 3:
                why.append(f"at least 3 bright two-image levels (found {n})")
            if no_dark:
                why.append("a two-image dark level at each exposure time (missing at "
                           + ", ".join(f"{t:g}" for t in no_dark[:5]) + (" ..." if len(no_dark) > 5 else "") + " ns)")
            need["photon transfer"] = "; ".join(why)
        elif n < min_steps:
            cov.missing.append(("(accuracy)", f"{MIN_STEPS - n} more photon-transfer steps: 4.0 Linear Section 6.5 "
                                              f"asks for at least {MIN_STEPS} (found {n}; {MIN_STEPS_PRODUCTION} for "
                                              "production measurements)"))
        if not photons_known:
            zero = sum(lv.photons <= 0 for lv in tb)
            need["photon counts"] = (f"photon counts (or E=/P= readings with w/a records) for every bright level: "
                                     f"{zero} of {n} have 0")
        if not area:
            need["pixel area"] = "the pixel area: an 'a UM2' record or --pixel-size-um"
        nexp_dark = len({round(t, 3) for t in darks})
        min_dark = MIN_DARK_EXPOSURES_40 if is40 else MIN_DARK_EXPOSURES_3X
        if nexp_dark < min_dark:
            need["dark current"] = (f"dark images at {min_dark - nexp_dark} more exposure times ({nexp_dark} of "
                                    f"{min_dark}" + (", 4.0 Linear Section 7.1: at least six equally spaced, best up "
                                                     "to the longest exposure the maker recommends)" if is40 else ")"))
        if not sb:
            need["stacks"] = "an averaged bright stack (one 'b' level with more than 2 images) at ~50 % saturation"
        elif not stack_dark:
            need["stacks"] = f"an averaged dark stack at the bright stack's exposure ({sb[0].exposure_ns:g} ns)"
        elif is40:
            L = min(len(sb[0].images), len(stack_dark[0].images))
            if L < MIN_STACK_40:
                cov.missing.append(("(accuracy)", f"stacks of at least {MIN_STACK_40} images (4.0 Linear Section 8: "
                                                  f"L = 100 - 500; found {L})"))
        for group, figs in _figures(release).items():
            why = need.get(group)
            if not why and group != "photon transfer":  # everything else is read off the photon transfer
                why = need.get("photon transfer")
            if not why and group == "pixel area":  # the per-area figures divide the photon-count ones
                why = need.get("photon counts")
            if why:
                cov.missing.append((", ".join(figs), why))
            else:
                cov.supported.extend(figs)
        if release == "4.0 General":
            cov.missing.append(("QE, K, 1/K", "never: not defined in the General model (General Section 6.7)"))
        out.append(cov)
    return out


def format_coverage(desc, covs: list[Coverage]) -> str:
    tb = desc.temporal_bright
    lines = [f"EMVA 1288 coverage of {desc.path}: {len(tb)} bright and {len(desc.temporal_dark)} dark two-image levels, "
             f"{len({lv.exposure_ns for lv in tb})} exposure times, stacks: "
             + (", ".join(f"{'dark' if lv.dark else 'bright'} L={len(lv.images)}"
                          for lv in desc.spatial_bright + desc.spatial_dark) or "none")]
    for c in covs:
        lines += ["", f"Release {c.release}", "  supported: " + (", ".join(c.supported) or "nothing")]
        for figs, why in c.missing:
            if figs == "(accuracy)":
                lines.append(f"  a full datasheet still needs {why}")
            elif why.startswith("never:"):
                lines.append(f"  never available: {figs} ({why[6:].strip()})")
            else:
                lines.append(f"  missing {figs}: needs {why}")
    lines += ["", "not checked without the images: whether the series reaches saturation and where the bright stack "
                  "lies (4.0 Linear Section 8: ~50 %); ares emva reports both"]
    return "\n".join(lines)
