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

from ares.errors import InputError

# numpy, scipy and the analysis are imported when the command runs (`ares --help` stays light)

NAME = "emva"
HELP = "EMVA 1288 parameters of a recorded data set (descriptor file)"


@dataclass
class EmvaAnalysis:
    descriptor: EmvaDescriptor
    emva: Emva1288Result
    ptc: PtcResult
    bright: list[LevelStats]  # Release 4.0 variance (offset-corrected), for ARES's PTC
    dark: list[LevelStats]
    emva4: "Emva4Result | None" = None  # the Release 4.0 Linear parameter set


def attribution_for(desc: EmvaDescriptor) -> str:
    """The attribution line to show with results; the Basler notice for the reference set."""
    from ares.analysis.emva1288 import ATTRIBUTION

    try:
        head = desc.path.read_text(errors="replace")[:2000]
    except OSError:
        head = ""
    if "Basler" in head:
        return ATTRIBUTION
    return f"data: {desc.path}"


def analyse_descriptor(path: str | Path | EmvaDescriptor) -> EmvaAnalysis:
    import numpy as np

    from ares.analysis.emva1288 import TemporalData, emva1288_results
    from ares.analysis.levels import pair_stats, spatial_stats
    from ares.analysis.ptc import analyze_ptc
    from ares.hardware.emva_descriptor import EmvaDescriptor, iter_level, load_level, read_descriptor

    desc = path if isinstance(path, EmvaDescriptor) else read_descriptor(path)
    max_code = (1 << desc.bits) - 1
    tb = desc.temporal_bright
    if len(tb) < 3:
        raise InputError(f"{desc.path}: needs at least 3 bright photon-transfer levels, found {len(tb)}")
    b3, d3, b4, d4 = [], [], [], []
    cache: dict[float, tuple[LevelStats, LevelStats]] = {}
    for lv in tb:
        a = load_level(desc, lv)
        b3.append(pair_stats(a[0], a[1], max_code, offset_correction=False))
        b4.append(pair_stats(a[0], a[1], max_code, offset_correction=True))
        dl = desc.dark_for(lv, "temporal")
        if dl.exposure_ns not in cache:
            d = load_level(desc, dl)
            cache[dl.exposure_ns] = (pair_stats(d[0], d[1], max_code, offset_correction=False),
                                     pair_stats(d[0], d[1], max_code, offset_correction=True))
        d3.append(cache[dl.exposure_ns][0])
        d4.append(cache[dl.exposure_ns][1])
    texp = np.array([lv.exposure_s for lv in tb])
    up = np.array([lv.photons for lv in tb])
    td = TemporalData(texp, up, np.array([x.mean for x in b3]), np.array([x.var for x in b3]),
                      np.array([x.mean for x in d3]), np.array([x.var for x in d3]), b3[0].n_pixels)
    sb = sd = None
    if desc.spatial_bright:
        lv = desc.spatial_bright[0]
        sb = spatial_stats(iter_level(desc, lv))  # streamed: memory does not grow with the stack
        sd = spatial_stats(iter_level(desc, desc.dark_for(lv, "spatial")))
    res = emva1288_results(td, sb, sd)
    ptc = analyze_ptc(b4, d4, exposure_s=texp, photons=up)
    from ares.analysis.emva4 import emva4_linear

    return EmvaAnalysis(desc, res, ptc, b4, d4, emva4_linear(b4, d4, up, dark_exposure_s=texp))


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
            ("read noise", p.read_noise_e), ("read noise", p.read_noise_dn)]
    rows += [(f"full well {k}", v) for k, v in p.full_well_e.items()]
    rows += [("dynamic range", p.dynamic_range_db), ("linearity err", p.linearity_error_pct)]
    for name, e in rows:
        lines.append(f"{name:<24}{e.text(with_unit=False):>24}  {e.unit:<6} {e.note}")
    ex = p.excluded()
    if ex:
        lines.append(f"excluded levels ({len(ex)}):")
        for i, why in ex:
            lines.append(f"  level {i}: {why}")
    lines += ["", attribution_for(an.descriptor)]
    return "\n".join(lines)


def write_pdf(an: EmvaAnalysis, out: Path) -> None:
    import numpy as np

    from ares.analysis.emva1288 import REFERENCE_NAMES

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    att = attribution_for(an.descriptor)
    td = an.emva.temporal
    Y = td.u_y - td.u_ydark
    V = td.s2_y - td.s2_ydark
    K = an.emva.values["K"].value
    with PdfPages(out) as pdf:
        fig, ax = plt.subplots(2, 2, figsize=(11, 8.5))
        ax[0, 0].plot(Y, V, "o", ms=3, label="data")
        xs = np.linspace(0, Y[an.emva.index_sensitivity_max], 10)
        ax[0, 0].plot(xs, K * xs, "-", label=f"K = {an.emva.values['K'].text()}")
        ax[0, 0].set(xlabel="mu_y - mu_y.dark [DN]", ylabel="s2_y - s2_y.dark [DN^2]", title="Photon transfer")
        ax[0, 0].legend()
        snr = np.where(td.s2_y > 0, Y / np.sqrt(np.maximum(td.s2_y, 1e-12)), np.nan)
        ax[0, 1].loglog(td.u_p, np.maximum(snr, 1e-3), "o", ms=3)
        ax[0, 1].set(xlabel="photons per pixel", ylabel="SNR", title="SNR")
        ax[1, 0].plot(td.u_p, an.emva.linearity_deviation_pct, "o", ms=3)
        ax[1, 0].set(xlabel="photons per pixel", ylabel="deviation [%]", title="Linearity error",
                     ylim=(-5, 5))
        ax[1, 1].axis("off")
        text = "\n".join(f"{k:<13} {an.emva.values[k].text()}" for k in REFERENCE_NAMES)
        ax[1, 1].text(0, 1, text, family="monospace", va="top", fontsize=9)
        fig.suptitle(f"EMVA 1288 (Release 3.0): {an.descriptor.path.name}")
        fig.text(0.5, 0.01, att, ha="center", fontsize=8)
        pdf.savefig(fig)
        plt.close(fig)


RELEASES = ("4.0-linear", "3.0")
EMVA4_ORDER = (("K", "overall system gain"), ("R", "responsivity"), ("QE", "quantum efficiency"),
               ("sigma_y_dark", "temporal dark noise"), ("sigma_d", "temporal dark noise (no quantization)"),
               ("mu_p_min", "absolute sensitivity threshold"), ("mu_e_min", "absolute sensitivity threshold"),
               ("mu_y_sat", "saturation (above dark)"), ("mu_p_sat", "saturation capacity"),
               ("mu_e_sat", "saturation capacity"), ("SNR_max", "maximum SNR"), ("SNR_max_db", "maximum SNR"),
               ("DR", "dynamic range"), ("DR_db", "dynamic range"), ("LE", "linearity error"))


def format_table4(an: EmvaAnalysis) -> str:
    """The Release 4.0 Linear photon-transfer parameters, each with its SE or the reason."""
    r = an.emva4
    lines = [f"EMVA 1288 Release 4.0 Linear: {an.descriptor.path}",
             f"{'parameter':<14}{'value':>26}  {'unit':<9} meaning / definition"]
    for k, label in EMVA4_ORDER:
        e = r.values.get(k)
        if e is None:
            continue
        val = e.text(with_unit=False) if e.available else "n/a"
        lines.append(f"{k:<14}{val:>26}  {e.unit:<9} {label}: {e.note}")
    lines += [f"saturation: {r.saturation}"] + [f"note: {n}" for n in r.notes]
    lines += ["not yet in this release's evaluation: the 4.0 spatial nonuniformity (Section 8: DSNU/PRNU with "
              "the 4.0 high-pass, row/column/pixel split), spectrograms and the defect histograms; "
              "`--release 3.0` prints DSNU1288/PRNU1288 by the 3.0 definitions", "", attribution_for(an.descriptor)]
    return "\n".join(lines)


def add_arguments(parser) -> None:
    parser.add_argument("descriptor", help="EMVA 1288 descriptor file (e.g. EMVA1288_Data.txt)")
    parser.add_argument("--release", choices=RELEASES, default="4.0-linear",
                        help="definitions to evaluate by (default 4.0-linear; 3.0 reproduces the reference "
                             "data set's published values)")
    parser.add_argument("--json", action="store_true", help="print the parameter set as JSON")
    parser.add_argument("--pdf", metavar="FILE", help="write a PDF report (Release 3.0 pages)")


def run(args) -> int:
    an = analyse_descriptor(args.descriptor)
    if args.release == "4.0-linear":
        d = {"release": "EMVA 1288 Release 4.0 Linear", **an.emva4.to_json(), "saturation": an.emva4.saturation,
             "linear_model_holds": an.emva4.linear, "notes": an.emva4.notes}
        text = format_table4
    else:
        d = {**an.emva.to_json(), "index_u_ysat": an.emva.index_u_ysat}
        text = format_table
    if args.json:
        d["attribution"] = attribution_for(an.descriptor)
        print(json.dumps(d, indent=2, default=lambda x: None if isinstance(x, float) and math.isnan(x) else x))
    else:
        print(text(an))
    if args.pdf:
        write_pdf(an, Path(args.pdf))
    return 0
