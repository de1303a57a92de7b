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
from dataclasses import dataclass
from pathlib import Path

from ares.commands.argtypes import positive
from ares.errors import InputError

# numpy, scipy and the analysis are imported when the command runs (`ares --help` stays light)

NAME = "emva"
HELP = "EMVA 1288 parameters of a recorded data set (descriptor file)"


@dataclass
class EmvaAnalysis:
    descriptor: EmvaDescriptor
    emva: Emva1288Result  # Release 3.0 definitions
    ptc: PtcResult
    bright: list[LevelStats]  # Release 4.0 variance (offset-corrected), for ARES's PTC
    dark: list[LevelStats]
    emva4: "Emva4Result | None" = None  # the Release 4.0 Linear photon-transfer set
    sheet: "EmvaSheet | None" = None  # Release 4.0 Linear, every Table 2 figure and the graph data
    general: "GeneralResult | None" = None  # Release 4.0 General
    release31: "dict | None" = None  # Release 3.1: the 3.0 set with the 5x5 high-pass DSNU/PRNU


def _pair(desc, lv, max_code):
    import itertools

    from ares.analysis.levels import pair_step
    from ares.hardware.emva_descriptor import iter_level

    # the two images as read (not stacked into a copy), referenced only by pair_step, which
    # lets them go once it has their sums (passed as pair_step(*two), the argument tuple
    # would hold them to its end: 1.2 MB a thread through the high-pass)
    two = itertools.islice(iter_level(desc, lv), 2)  # (a temporal level has two: read_descriptor)
    return pair_step(next(two), next(two), max_code)


def _stack(desc, lv):
    """A stack level, streamed: its ``SpatialStats`` and its ``StackImage`` with what every
    release reads from it computed (in a worker thread, beside the other images)."""
    from ares.analysis.emva4_sheet import StackImage
    from ares.analysis.levels import stack_moments
    from ares.hardware.emva_descriptor import iter_level

    st, img, line, total = stack_moments(iter_level(desc, lv))
    return st, StackImage(img, st.s2_temporal, st.n_frames, lv.photons, lv.exposure_s, line, total).prepare()


def analyse_descriptor(path: str | Path | EmvaDescriptor, pixel_area_um2: float | None = None) -> EmvaAnalysis:
    """Every release's statistics in one pass over the images (each image decoded once;
    the stacks streamed, memory independent of their length)."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    import numpy as np

    from ares.analysis import emva_spatial, levels  # noqa: F401 -- loaded before the threads need them
    from ares.hardware.emva_descriptor import EmvaDescriptor, read_descriptor

    desc = path if isinstance(path, EmvaDescriptor) else read_descriptor(path)
    max_code = (1 << desc.bits) - 1
    tb = desc.temporal_bright
    if len(tb) < 3:
        raise InputError(f"{desc.path}: needs at least 3 bright photon-transfer levels, found {len(tb)}")
    b3, d3, b4, d4, steps, diffs = [], [], [], [], [], []
    darks = {}
    for lv in tb:
        dl = desc.dark_for(lv, "temporal")
        darks.setdefault(dl.exposure_ns, dl)
    stack_levels = []
    if desc.spatial_bright:
        lv = desc.spatial_bright[0]
        stack_levels = [lv, desc.dark_for(lv, "spatial")]
    # every image once, on all cores: inflating the PNGs and the numpy work release the GIL.
    # The two stacks (streamed: memory independent of their length) go first, the two-image
    # levels fill in around them; each task holds only its own images, and the results do
    # not depend on the order the threads finish in
    with ThreadPoolExecutor(min(os.cpu_count() or 1, 4)) as ex:
        stacks = [ex.submit(_stack, desc, lv) for lv in stack_levels]
        bright = ex.map(lambda lv: _pair(desc, lv, max_code), tb)
        dark = ex.map(lambda lv: _pair(desc, lv, max_code), darks.values())
        # the fits' modules load while the images are read (the threads hardly need the GIL)
        from ares.analysis.emva1288 import TemporalData, emva1288_results
        from ares.analysis.emva4_sheet import EmvaInput, evaluate_linear
        from ares.analysis.emva_general import emva_general
        from ares.analysis.ptc import analyze_ptc

        bright, dark = list(bright), dict(zip(darks, dark))
        stacks = [f.result() for f in stacks]
    from ares import malloc

    malloc.release()  # the threads' freed temporaries, before the fits' and graphs' own
    for lv, (s3, s4, sp, md) in zip(tb, bright):
        b3.append(s3)
        b4.append(s4)
        diffs.append(md)
        dk = dark[desc.dark_for(lv, "temporal").exposure_ns]
        d3.append(dk[0])
        d4.append(dk[1])
        steps.append((sp, dk[2]))
    texp = np.array([lv.exposure_s for lv in tb])
    up = np.array([lv.photons for lv in tb])
    td = TemporalData(texp, up, np.array([x.mean for x in b3]), np.array([x.var for x in b3]),
                      np.array([x.mean for x in d3]), np.array([x.var for x in d3]), b3[0].n_pixels)
    sb = sd = stack_b = stack_d = None
    if stacks:
        (sb, stack_b), (sd, stack_d) = stacks
    res = emva1288_results(td, sb, sd)
    ptc = analyze_ptc(b4, d4, exposure_s=texp, photons=up)
    inp = EmvaInput(up, texp, b4, d4, steps, np.array(diffs), stack_d, stack_b, pixel_area_um2=pixel_area_um2,
                    meta={"source": str(desc.path), "bits": desc.bits, "width": desc.width, "height": desc.height})
    sheet = evaluate_linear(inp)
    general = emva_general(b4, d4, up, mean_diff=np.array(diffs))
    r31 = None
    if stack_b is not None:
        r31 = release31(res, stack_b, stack_d)
    return EmvaAnalysis(desc, res, ptc, b4, d4, sheet.photon_transfer, sheet, general, r31)


def release31(res, stack_b, stack_d) -> dict:
    """Release 3.1 = the 3.0 set with DSNU1288/PRNU1288 from 5x5-box high-passed stacks,
    the spatial standard deviation divided by 0.96 (Linear 4.0 Appendix C.5, Eqs. 84 - 86)."""
    from ares.analysis.estimate import Estimate

    K = res.values["K"]
    out = {k: e for k, e in res.values.items()}

    def s2(st):  # Eq. 86: the filter keeps 0.96^2 of a white pattern and of the temporal residual
        return st.highpassed_var("3.1") / 0.96**2 - st.temporal_var / st.L

    try:
        d2, b2 = s2(stack_d), s2(stack_b)
    except ValueError as exc:  # smaller than the 5x5 filter
        out["DSNU1288"] = Estimate.na(str(exc), "e-")
        out["PRNU1288"] = Estimate.na(str(exc), "%")
        return out
    sig = float(stack_b.mean_image.mean() - stack_d.mean_image.mean())
    out["DSNU1288"] = (Estimate(math.sqrt(d2) / K.value, math.sqrt(d2) / K.value * K.se / K.value, "e-",
                                "s_y.dark after the 5x5 high-pass / 0.96, / K (Release 3.1, Appendix C.5)")
                       if d2 > 0 else Estimate.na("no dark spatial variance above the temporal residual", "e-"))
    out["PRNU1288"] = (Estimate(100 * math.sqrt(b2 - d2) / sig, math.nan, "%",
                                "sqrt(s2_y.50 - s2_y.dark) after the 5x5 high-pass / 0.96, / (mu_y.50 - mu_y.dark) "
                                "(Release 3.1)")
                       if b2 > d2 and sig > 0 else Estimate.na("no spatial signal variance above dark", "%"))
    return out


def format_table(an: EmvaAnalysis) -> str:
    from ares.analysis.emva1288 import REFERENCE_NAMES

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

    from ares.analysis.emva1288 import REFERENCE_NAMES

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
    lines = [f"{'quantity':<20}{'symbol':<15}{'value':>26}  {'unit':<10} definition / reason"]
    for k, e in values.items():
        val = e.text(with_unit=False) if e.available else "n/a"
        lines.append(f"{k:<20}{(symbols or {}).get(k, k):<15}{val:>26}  {e.unit:<10} {e.note}")
    return lines


def format_table4(an: EmvaAnalysis) -> str:
    """Every Release 4.0 Linear figure of Table 2 (and R, mu_p.min/sat), with its SE or verdict."""
    from ares.analysis.emva4_sheet import SYMBOLS

    sh = an.sheet
    lines = [f"{sh.release}: {an.descriptor.path}", *_value_lines(sh.values, SYMBOLS),
             f"saturation: {sh.photon_transfer.saturation}"]
    lines += [f"note: {n}" for n in sh.notes] + ["", an.descriptor.attribution]
    return "\n".join(lines)


def format_general(an: EmvaAnalysis) -> str:
    g = an.general
    lines = [f"EMVA 1288 Release 4.0 General: {an.descriptor.path}", *_value_lines(g.values),
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
    parser.add_argument("--json", action="store_true", help="print the parameter set as JSON")
    parser.add_argument("--csv", metavar="FILE", help="write the parameter set as CSV (quantity, symbol, value, "
                                                      "SE, unit, verdict, definition)")
    parser.add_argument("--pdf", metavar="FILE", help="write the PDF: the EMVA 1288 datasheet (Release 4.0: summary "
                                                      "sheet and every mandatory graph) or the Release 3.x page")
    for opt, what in (("--vendor", "camera vendor"), ("--model", "camera model"), ("--serial", "serial number"),
                      ("--date", "measurement date (the datasheet must state it)")):
        parser.add_argument(opt, help=f"{what}, for the datasheet header")
    parser.add_argument("--wavelength-nm", type=positive, help="light source centroid wavelength (nm)")
    parser.add_argument("--pixel-size-um", type=positive, help="pixel pitch (um): gives mu_e.min.area and mu_e.sat.area")


def _meta(args, an: EmvaAnalysis) -> None:
    m = an.sheet.meta
    for k in ("vendor", "model", "serial", "date"):
        if getattr(args, k, None):
            m[k] = getattr(args, k)
    if getattr(args, "wavelength_nm", None):
        m["wavelength_nm"] = args.wavelength_nm
        m["wavelength"] = f"{args.wavelength_nm:g} nm"
    m.setdefault("date", "not recorded in the descriptor")
    m["footer"] = an.descriptor.attribution
    m["data_mode"] = f"Mono {an.descriptor.bits}"
    m["exposure_control"] = "exposure time"


def run(args) -> int:
    from ares import jit

    pitch = getattr(args, "pixel_size_um", None)
    # one data set: numba's import and first load (~0.5 s, ~100 MB) cost what its kernels
    # save here (benchmarks/peer.md), and the numpy paths give the same figures
    with jit.avoided():
        an = analyse_descriptor(args.descriptor, pitch * pitch if pitch else None)  # the .area figures need it
    _meta(args, an)
    att = an.descriptor.attribution
    if args.release == "4.0-linear":
        d = an.sheet.to_json()
        text = format_table4
    elif args.release == "4.0-general":
        d = {"release": "EMVA 1288 Release 4.0 General", "values": an.general.to_json(),
             "saturation": an.general.saturation, "notes": an.general.notes}
        text = format_general
    elif args.release == "3.1":
        d = {"release": "EMVA 1288 Release 3.1", "values": {k: e.to_dict() for k, e in (an.release31 or {}).items()}}
        text = format_table31
    else:
        d = {**an.emva.to_json(), "index_u_ysat": an.emva.index_u_ysat}
        text = format_table
    if args.json:
        d["attribution"] = att
        print(json.dumps(d, indent=2, default=lambda x: None if isinstance(x, float) and math.isnan(x) else x))
    else:
        print(text(an))
    if args.csv or args.pdf:
        from ares.report import datasheet  # matplotlib: only for the files that need it
    if args.csv:
        from ares.scan.rundir import write_atomic

        gen = an.general if args.release == "4.0-general" else None
        write_atomic(Path(args.csv), datasheet.to_csv(an.sheet, gen).encode())
    if args.pdf:
        if args.release.startswith("4.0"):
            datasheet.write_datasheet(an.sheet, Path(args.pdf),
                                      an.general if args.release == "4.0-general" else None)
        else:
            write_pdf(an, Path(args.pdf), args.release)
    return 0
