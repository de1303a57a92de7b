"""``ares emva DESCRIPTOR``: the EMVA 1288 parameter set of a recorded data set.

Reads an EMVA 1288 descriptor file, streams its images level by level (memory: one
level at a time), and prints the EMVA 1288 (Release 3.0) parameters next to ARES's own
photon-transfer results. ``--json`` prints the reference names
(K, sigma_y_dark, u_e_sat, QE, SNR_max, DR, u_I_mean, DSNU1288, PRNU1288, LE_min,
LE_max) as ``{value, se, unit}``; ``--pdf FILE`` writes a short report.
"""

from __future__ import annotations

import json
import math
import dataclasses
from pathlib import Path

from ares.commands.argtypes import positive
from ares.results.descriptor import EmvaAnalysis, analyse_descriptor, with_pair_variance

# numpy, scipy and the analysis are imported when the command runs (`ares --help` stays light)

NAME = "emva"
HELP = "EMVA 1288 parameters of a recorded data set (descriptor file)"


def beside(values: dict, extra: dict) -> dict:
    """``values`` with each key of ``extra`` replaced in place, or (a new key ``<key>_...`` or
    ``<key>.<option>``) inserted right after the entry it belongs to."""
    out = dict(values)
    out.update({k: e for k, e in extra.items() if k in values})
    for k, e in extra.items():
        if k in values:
            continue
        base = k.split(".")[0]
        while base and base not in out:
            base = base.rpartition("_")[0]
        if not base:
            out[k] = e
            continue
        items = list(out.items())
        i = [a for a, _ in items].index(base) + 1
        while i < len(items) and (items[i][0].startswith(base + ".") or items[i][0].startswith(base + "_upper")):
            i += 1
        out = dict(items[:i] + [(k, e)] + items[i:])
    return out


EXTENSIONS = {
    "rowcol_corrected": "DSNU1288/PRNU1288 .row/.col/.pix with the high-pass gains of 1-D and 2-D white patterns and "
                        "the measured row/column temporal noise removed (beyond Eqs. 39 - 41)",
    "eq51_noise_floor": "the Eq. 51 local-slope check with at most 3 quantile knots over 0 - 70 % and the noise of "
                        "the local slopes removed (beyond Eq. 51)",
    "mu_e_sat_fit": "mu_e.sat as (mu_y.sat - mu_y.dark) / K (beyond Eq. 24, which takes the measured photons)",
}


def apply_extensions(an: EmvaAnalysis, names) -> None:
    """Add the values of ARES's named options (``EXTENSIONS``) beside the text's, each keyed
    ``<key>.<option>`` and labelled in its note; the text's values are left as they are."""
    from ares.analysis.emva.gain_term import attribute
    from ares.analysis.spatial.nonuniformity import nonuniformity_rowcol_corrected

    sh, pt = an.sheet, an.sheet.photon_transfer
    extra = {}
    K = sh.values["K"]
    if "rowcol_corrected" in names and an.inp is not None and an.inp.stack_dark is not None and K.available:
        sd, sb = an.inp.stack_dark, an.inp.stack_bright
        try:
            ds, bs = sd.split("4.0"), sb.split("4.0") if sb is not None else None
        except ValueError:
            ds, bs = sd.split("none"), sb.split("none") if sb is not None else None
        gt = pt.gain_term  # in e-: K as the zero-signal gain, as the text's DSNU1288 (ares.analysis.emva.gain_term)
        rc = nonuniformity_rowcol_corrected(ds, bs, K.value, gt.se if gt is not None else K.se)
        extra.update(attribute(rc, nonuniformity_rowcol_corrected(ds, bs, K.value, K.se), gt) if gt is not None else rc)
    if "eq51_noise_floor" in names and pt.linear_noise_floor is not None:
        sh.notes.append("ARES option eq51_noise_floor (beyond Eq. 51): " + pt.linear_noise_floor.note)
    if "mu_e_sat_fit" in names and pt.mu_e_sat_fit is not None:
        e = pt.mu_e_sat_fit
        extra["mu_e_sat.mu_e_sat_fit"] = dataclasses.replace(e, note="ARES option mu_e_sat_fit, beyond Eq. 24: " + e.note)
    sh.values = beside(sh.values, extra)


def eq51_json(pt) -> dict:
    """The Eq. 51 check as written (and ARES's variant, labelled) for the JSON."""
    def one(c):
        if c is None:
            return None
        return {"mean_rel_dev_pct": 100 * c.mean_rel_dev if math.isfinite(c.mean_rel_dev) else None,
                "holds": c.holds, "intervals": c.intervals or None, "note": c.note}
    return {"as_written": one(pt.linear_check),
            "eq51_noise_floor": {**(one(pt.linear_noise_floor) or {}),
                                 "option": "ARES option eq51_noise_floor, beyond the text"}}


def format_table(an: EmvaAnalysis) -> str:
    from ares.analysis.emva.release3 import REFERENCE_NAMES

    lines = [f"EMVA 1288 (Release 3.0 definitions): {an.descriptor.path}",
             f"{'parameter':<14}{'value':>22}  unit   definition"]
    for k in REFERENCE_NAMES:
        e = an.emva.values[k]
        lines.append(f"{k:<14}{e.text(with_unit=False):>22}  {e.unit:<6} {e.note}")  # digits from the SE
    lines.append(f"{'index_u_ysat':<14}{an.emva.index_u_ysat:>22}")
    p = an.ptc
    lines += ["", "ARES photon transfer (Release 4.0 pair variance, weighted fits):"]
    rows = [("gain (WLS)", p.gain_dn_per_e), ("gain (origin)", p.gain_origin_dn_per_e),
            ("gain (Astier)", p.gain_astier_dn_per_e), ("1/gain", p.gain_e_per_dn),
            ("read noise sigma_d", p.read_noise_e), ("dark noise sig_y.d", p.read_noise_dn)]
    rows += [(f"full well {k}", v) for k, v in p.full_well_e.items()]
    rows += [("dynamic range", p.dynamic_range_db), ("linearity err", p.linearity_error_pct)]
    for name, e in rows:
        lines.append(f"{name:<24}{e.text(with_unit=False):>24}  {e.unit:<6} {e.note}")
    ex = p.excluded()
    if ex:
        lines.append(f"excluded levels ({len(ex)}):")
        for i, why in ex:
            lines.append(f"  level {i}: {why}")
    lines += ["", an.descriptor.attribution]
    return "\n".join(lines)


def write_pdf(an: EmvaAnalysis, out: Path, release: str = "3.0") -> None:
    import numpy as np

    from ares.analysis.emva.release3 import REFERENCE_NAMES

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    att = an.descriptor.attribution
    td = an.emva.temporal
    Y = td.u_y - td.u_ydark
    V = td.s2_y - td.s2_ydark
    K = an.emva.values["K"].value
    with PdfPages(out) as pdf:
        fig, ax = plt.subplots(2, 2, figsize=(11, 8.5))
        fig.subplots_adjust(hspace=0.32)  # the upper plots' axis labels clear the lower plots' titles
        ax[0, 0].plot(Y, V, "o", ms=3, label="data")
        if an.emva.values["K"].available:
            xs = np.linspace(0, Y[an.emva.index_sensitivity_max], 10)
            ax[0, 0].plot(xs, K * xs, "-", label=f"K = {an.emva.values['K'].text()}")
        ax[0, 0].set(xlabel="mu_y - mu_y.dark [DN]", ylabel="s2_y - s2_y.dark [DN^2]", title="Photon transfer")
        ax[0, 0].legend()
        snr = np.where(td.s2_y > 0, Y / np.sqrt(np.maximum(td.s2_y, 1e-12)), np.nan)
        lit = td.u_p > 0
        if lit.any():
            ax[0, 1].loglog(td.u_p[lit], np.maximum(snr[lit], 1e-3), "o", ms=3)
        else:
            ax[0, 1].text(0.5, 0.5, "no photon counts in the data set", ha="center", transform=ax[0, 1].transAxes)
        ax[0, 1].set(xlabel="photons per pixel", ylabel="SNR", title="SNR")
        ax[1, 0].plot(td.u_p, an.emva.linearity_deviation_pct, "o", ms=3)
        ax[1, 0].set(xlabel="photons per pixel", ylabel="deviation [%]", title="Linearity error",
                     ylim=(-5, 5))
        ax[1, 1].axis("off")
        vals = an.release31 if release == "3.1" and an.release31 else an.emva.values
        text = "\n".join(f"{k:<13} {vals[k].text()}" for k in REFERENCE_NAMES if k in vals)
        ax[1, 1].text(0, 1, text, family="monospace", va="top", fontsize=9)
        fig.suptitle(f"EMVA 1288 (Release {release}): {an.descriptor.path.name}")
        fig.text(0.5, 0.01, att, ha="center", fontsize=8)
        pdf.savefig(fig)
        plt.close(fig)


RELEASES = ("4.0-linear", "4.0-general", "3.1", "3.0")


def _value_lines(values: dict, symbols: dict | None = None) -> list[str]:
    sw = max([15] + [len((symbols or {}).get(k, k)) + 1 for k in values])  # a long symbol shifted the values
    vals = {k: e.text(with_unit=False) if e.available else "n/a" for k, e in values.items()}
    vw = max([26] + [len(v) for v in vals.values()])  # an exact value's verdict widens the column, never shifts a row
    lines = [f"{'quantity':<20}{'symbol':<{sw}}{'value':>{vw}}  {'unit':<10} definition / reason"]
    for k, e in values.items():
        lines.append(f"{k:<20}{(symbols or {}).get(k, k):<{sw}}{vals[k]:>{vw}}  {e.unit:<10} {e.note}")
    return lines


def format_table4(an: EmvaAnalysis) -> str:
    """Every Release 4.0 Linear figure of Table 2 (and R, mu_p.min/sat), with its SE or verdict."""
    from ares.analysis.emva.sheet import SYMBOLS

    sh = an.sheet
    lines = [f"{sh.release}: {an.descriptor.path}", *_value_lines(sh.values, SYMBOLS),
             f"saturation: {sh.photon_transfer.saturation}"]
    lines += [f"note: {n}" for n in sh.notes] + ["", an.descriptor.attribution]
    return "\n".join(lines)


def format_general(an: EmvaAnalysis) -> str:
    from ares.analysis.emva.general_table import GENERAL_TABLE2

    g = an.general
    lines = [f"EMVA 1288 Release 4.0 General: {an.descriptor.path}",
             *_value_lines(g.values, {k: s for k, s, _ in GENERAL_TABLE2}),
             f"saturation: {g.saturation}"]
    lines += [f"note: {n}" for n in g.notes]
    lines += ["K, the quantum efficiency and values in electrons are not defined in the General model "
              "(General Section 6.7)", "", an.descriptor.attribution]
    return "\n".join(lines)


def format_table31(an: EmvaAnalysis) -> str:
    lines = [f"EMVA 1288 Release 3.1: {an.descriptor.path}", *_value_lines(an.release31 or {})]
    lines += ["Release 3.1 as documented in Appendix D of Release 4.0 Linear: the 3.0 set with DSNU1288/PRNU1288 "
              "from 5x5 high-passed stacks (Appendix C.5); the 3.1 saturation search refinement is not specified in "
              "the texts ARES has, so saturation is the 3.0 maximum-variance level", "", an.descriptor.attribution]
    return "\n".join(lines)


def add_arguments(parser) -> None:
    parser.add_argument("descriptor", help="EMVA 1288 descriptor file (e.g. EMVA1288_Data.txt)")
    parser.add_argument("--release", choices=RELEASES, default="4.0-linear",
                        help="definitions to evaluate by (default 4.0-linear; 3.0 reproduces the reference "
                             "data set's published values)")
    parser.add_argument("--pair-variance", choices=("3.x", "4.0"), default="3.x",
                        help="temporal variance of a pair for --release 3.0/3.1: 3.x (default, as those releases "
                             "define it) or 4.0 (Linear Eq. 18, the mean difference removed: what the reference "
                             "implementation emva1288 1.0.2 computes; docs/emva1288_releases.md)")
    parser.add_argument("--json", action="store_true", help="print the parameter set as JSON")
    parser.add_argument("--missing", action="store_true",
                        help="only report, from the descriptor alone, which figures of each release the data set "
                             "supports and which steps a full datasheet still needs")
    parser.add_argument("--csv", metavar="FILE", help="write the parameter set as CSV (quantity, symbol, value, "
                                                      "SE, unit, verdict, definition)")
    parser.add_argument("--xml", metavar="FILE", help="write the results in the EMVA 1288 certification XML "
                                                      "(the reference implementation's names for 3.x, the Table 2 "
                                                      "names for 4.0; docs/emva_xml.md), for ares emva-compare")
    parser.add_argument("--pdf", metavar="FILE", help="write the PDF: the EMVA 1288 datasheet (Release 4.0: summary "
                                                      "sheet and every mandatory graph) or the Release 3.x page")
    for opt, what in (("--vendor", "camera vendor"), ("--model", "camera model"), ("--serial", "serial number"),
                      ("--date", "measurement date (the datasheet must state it)")):
        parser.add_argument(opt, help=f"{what}, for the datasheet header")
    parser.add_argument("--wavelength-nm", type=positive, help="light source centroid wavelength (nm)")
    parser.add_argument("--pixel-size-um", type=positive, help="pixel pitch (um): gives mu_e.min.area and mu_e.sat.area, "
                                                              "and the pixel area of E=/P= levels")
    parser.add_argument("--detector-area-mm2", type=positive,
                        help="power-meter detector area (mm^2) for the descriptor's P= levels (power readings, W)")
    parser.add_argument("--extension", action="append", choices=sorted(EXTENSIONS), default=[],
                        help="also give the value of one of ARES's methods beyond the text (repeatable), beside the "
                             "text's value and labelled: " + "; ".join(f"{k}: {v}" for k, v in EXTENSIONS.items()))


def _meta(args, an: EmvaAnalysis) -> None:
    m = an.sheet.meta
    for k in ("vendor", "model", "serial", "date"):
        if getattr(args, k, None):
            m[k] = getattr(args, k)
    lam = getattr(args, "wavelength_nm", None) or an.descriptor.wavelength_nm  # the option, else a 'w' record
    if lam:
        m["wavelength_nm"] = lam
        m["wavelength"] = f"{lam:g} nm"
    m.setdefault("date", "not recorded in the descriptor")
    m["footer"] = an.descriptor.attribution
    m["data_mode"] = f"Mono {an.descriptor.bits}"
    m["resolution"] = f"{an.descriptor.width} x {an.descriptor.height} pixels"
    if getattr(args, "pixel_size_um", None):
        m["pixel_size"] = f"{args.pixel_size_um:g} x {args.pixel_size_um:g} µm"
    elif an.descriptor.pixel_area_um2:
        m["pixel_size"] = f"{an.descriptor.pixel_area_um2:g} µm² (pixel area)"
    ts = sorted({lv.exposure_s for lv in an.descriptor.temporal_bright})
    if ts:
        m["exposure_time"] = f"{1e3 * ts[0]:.4g} - {1e3 * ts[-1]:.4g} ms" if len(ts) > 1 else f"{1e3 * ts[0]:.4g} ms"


# numba's kernels pay for their import and first load (~0.7 - 1 s of CPU on this project's
# busy 2-core VM, ~120 MB more peak RSS) in a set of more image pixels than this: the
# reference CCD set (92 Mpx) took 0.6 s more CPU with them, tiled 2x2 (368 Mpx) 0.6 s less
# (benchmarks/emva_highpass.md); the line through the two crosses zero near 240 Mpx
NUMBA_PAYS_PIXELS = 250e6


def uses_kernels(desc) -> bool:
    """Whether ``ares emva`` loads numba's kernels for ``desc``: a large set (every image's
    pixels above ``NUMBA_PAYS_PIXELS``); a small one takes the numpy paths, which give the
    same figures (exactly, or to float64 rounding: tested)."""
    n = sum(len(lv.images) for lv in desc.levels)
    return n * desc.width * desc.height > NUMBA_PAYS_PIXELS


def write_results_xml(an: EmvaAnalysis, release: str, out: Path, pixel_area_um2: float | None) -> None:
    """``--xml``: the certification tree of ``release`` (``ares.results.emva_names``) as XML."""
    from ares.report.emva_xml import write_xml
    from ares.results.emva_names import release31, release40

    if release.startswith("4.0"):
        tree = release40(an, release.split("-")[1])
    else:
        tree = release31(an, pixel_area_um2, release)
    write_xml(tree, release, out)


def run(args) -> int:
    import contextlib

    from ares.analysis.kernels import jit
    from ares.hardware.emva_descriptor import read_descriptor

    from ares.safefile import output_file, writing

    for opt, path in (("--csv", args.csv), ("--pdf", args.pdf)):  # before the work (ares.safefile)
        if path:
            output_file(path, opt)
    pitch = getattr(args, "pixel_size_um", None)
    if getattr(args, "missing", False):
        from ares.results.emva_missing import coverage, format_coverage

        desc = read_descriptor(args.descriptor, check_files=False, wavelength_nm=getattr(args, "wavelength_nm", None),
                               pixel_area_um2=pitch * pitch if pitch else None,
                               detector_area_mm2=getattr(args, "detector_area_mm2", None))
        covs = coverage(desc, pitch * pitch if pitch else None)
        if args.json:
            print(json.dumps([dataclasses.asdict(c) for c in covs], indent=2))
        else:
            print(format_coverage(desc, covs))
        return 0
    desc = read_descriptor(args.descriptor, wavelength_nm=getattr(args, "wavelength_nm", None),
                           pixel_area_um2=pitch * pitch if pitch else None,
                           detector_area_mm2=getattr(args, "detector_area_mm2", None))
    area = pitch * pitch if pitch else desc.pixel_area_um2  # the option, else the descriptor's 'a' record
    with contextlib.nullcontext() if uses_kernels(desc) else jit.avoided():
        an = analyse_descriptor(desc, area)  # the .area figures need it
    _meta(args, an)
    an = with_pair_variance(an, getattr(args, "pair_variance", None) or "3.x")
    apply_extensions(an, getattr(args, "extension", None) or [])
    att = an.descriptor.attribution
    if args.release == "4.0-linear":
        d = an.sheet.to_json()
        d["eq51"] = eq51_json(an.sheet.photon_transfer)
        text = format_table4
    elif args.release == "4.0-general":
        from ares.analysis.emva.general_table import GENERAL_TABLE2

        d = {"release": "EMVA 1288 Release 4.0 General", "values": an.general.to_json(),
             "saturation": an.general.saturation, "notes": an.general.notes}
        sym = {k: s for k, s, _ in GENERAL_TABLE2}
        for k, e in d["values"].items():
            if k in sym:
                e["symbol"] = sym[k]
        text = format_general
    elif args.release == "3.1":
        d = {"release": "EMVA 1288 Release 3.1", "values": {k: e.to_dict() for k, e in (an.release31 or {}).items()}}
        text = format_table31
    else:  # one shape for every release: {"release", "values", ...}
        d = {"release": "EMVA 1288 Release 3.0", "values": an.emva.to_json(), "index_u_ysat": an.emva.index_u_ysat}
        text = format_table
    if args.json:
        d["attribution"] = att
        print(json.dumps(d, indent=2, default=lambda x: None if isinstance(x, float) and math.isnan(x) else x))
    else:
        print(text(an))
    if getattr(args, "xml", None):
        write_results_xml(an, args.release, Path(args.xml), area)
    if args.csv or args.pdf:
        from ares.report import datasheet  # matplotlib: only for the files that need it
    if args.csv:
        from ares.rundir.files import write_atomic

        gen = an.general if args.release == "4.0-general" else None
        # the release asked for: 3.x writes its own values, not the 4.0 sheet's
        csv_text = datasheet.to_csv(an.sheet, gen) if args.release.startswith("4.0") else \
            datasheet.values_csv(d["release"], (an.release31 or {}) if args.release == "3.1" else an.emva.values, d["values"])
        with writing(args.csv):
            write_atomic(Path(args.csv), csv_text.encode())
    if args.pdf:
        with writing(args.pdf):
            if args.release.startswith("4.0"):
                datasheet.write_datasheet(an.sheet, Path(args.pdf), an.general, args.release)
            else:
                write_pdf(an, Path(args.pdf), args.release)
    return 0
