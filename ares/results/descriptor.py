"""An EMVA 1288 data set (descriptor file) analysed once for every release: its images decoded and streamed level by level (threads), Release 3.0/3.1, 4.0 Linear and General, and ARES's photon transfer; ``ares emva`` and ``ares batch`` print and tabulate it."""

from __future__ import annotations

import math
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from ares.errors import InputError


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
    inp: "EmvaInput | None" = None  # what the 4.0 evaluations read (the stacks: the extensions' splits)
    max_code: "int | None" = None  # the maximum value found in the data (Linear Section 6.6)
    spatial: "tuple | None" = None  # (bright, dark) SpatialStats of the stacks (Release 3.x DSNU1288/PRNU1288)


def _pair(desc, lv, max_code):
    import itertools

    import numpy as np

    from ares.analysis.ptc.levels import pair_step
    from ares.hardware.emva_descriptor import iter_level

    # the two images as read (not stacked into a copy), referenced only by pair_step, which
    # lets them go once it has their sums (passed as pair_step(*two), the argument tuple
    # would hold them to its end: 1.2 MB a thread through the high-pass)
    two = itertools.islice(iter_level(desc, lv), 2)  # (a temporal level has two: read_descriptor)
    a, b = next(two), next(two)
    top = max(a.max(), b.max())  # the largest value of the pair and how many samples have it
    at_top = (int(np.count_nonzero(a == top)) + int(np.count_nonzero(b == top))) / (a.size + b.size)
    return (*pair_step(a, b, max_code), (int(top), at_top))


def _stack(desc, lv):
    """A stack level, streamed: its ``SpatialStats`` and its ``StackImage`` with what every
    release reads from it computed (in a worker thread, beside the other images)."""
    from ares.analysis.emva.sheet import StackImage
    from ares.analysis.ptc.levels import stack_moments
    from ares.hardware.emva_descriptor import iter_level

    st, img, line, total = stack_moments(iter_level(desc, lv))
    return st, StackImage(img, st.s2_temporal, st.n_frames, lv.photons, lv.exposure_s, line, total).prepare()


def analyse_descriptor(path: str | Path | EmvaDescriptor, pixel_area_um2: float | None = None) -> EmvaAnalysis:
    """Every release's statistics in one pass over the images (each image decoded once;
    the stacks streamed, memory independent of their length)."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    import numpy as np

    from ares.analysis.spatial import nonuniformity as emva_spatial  # noqa: F401 -- loaded before the threads need them
    from ares.analysis.ptc import levels  # noqa: F401 -- loaded before the threads need them
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
        from ares.analysis.emva.release3 import TemporalData, emva1288_results
        from ares.analysis.emva.sheet import EmvaInput, evaluate_linear
        from ares.analysis.emva.general import general_from_input
        from ares.analysis.ptc.photon_transfer import analyze_ptc

        bright, dark = list(bright), dict(zip(darks, dark))
        stacks = [f.result() for f in stacks]
    from ares import malloc

    malloc.release()  # the threads' freed temporaries, before the fits' and graphs' own
    found = max(t[0] for *_, t in bright)  # Linear Section 6.6: the maximum value is found, not assumed
    for lv, (s3, s4, sp, md, (top, at_top)) in zip(tb, bright):
        if found != max_code:  # the fraction at the found maximum (0 where a level does not reach it)
            s3, s4 = (dataclasses.replace(x, frac_at_max=at_top if top == found else 0.0) for x in (s3, s4))
        b3.append(s3)
        b4.append(s4)
        diffs.append(md)
        dk = dark[desc.dark_for(lv, "temporal").exposure_ns]
        d3.append(dk[0])  # (dk[4], the dark pair's maximum, is not the saturation value)
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
    inp.notes.append(f"maximum value {found} DN, found in the data (EMVA 1288 4.0 Linear Section 6.6)"
                     + ("" if found == max_code else f"; not the {desc.bits}-bit 2^k - 1 = {max_code}"))
    sheet = evaluate_linear(inp)
    general = general_from_input(inp, sheet.photon_transfer)  # the whole General Table 2
    r31 = release31(res, stack_b, stack_d)  # (without the stacks: its DSNU1288/PRNU1288 say what they need)
    check_radiometric_qe(desc, {"Release 4.0 Linear": sheet.values["QE"], "Release 3.0": res.values["QE"]})
    return EmvaAnalysis(desc, res, ptc, b4, d4, sheet.photon_transfer, sheet, general, r31, inp, found,
                        (sb, sd) if stacks else None)


def check_radiometric_qe(desc, qes: dict) -> None:
    """Refuse photon counts converted from the lab's readings (``E=``/``P=`` levels) that make
    the quantum efficiency impossible: outside 0 - 100 % (eta is a fraction of the photons,
    Linear Eq. 2), with the numbers of the conversion -- a unit slip (uW/cm^2 read as W/m^2 is a
    factor 100; um^2 as mm^2 a factor 1e6) shows at once."""
    rad = getattr(desc, "radiometry", None)
    if rad is None:
        return
    for release, qe in qes.items():
        if qe.available and not 0 < qe.value <= 100:
            lv = next(lv for lv in desc.temporal_bright if lv.line in rad.readings)
            raise InputError(
                f"{desc.path}:{lv.line}: the photon counts converted from the lab's readings give a quantum efficiency "
                f"of {qe.value:.4g} % ({release}), outside 0 - 100 %: {rad.describe(lv.line, lv.exposure_s, lv.photons)}"
                f"; check the units (E in W/m^2 -- 1 uW/cm^2 = 0.01 W/m^2 --, P in W, A in um^2, the detector area "
                f"in mm^2)")


PAIR_VARIANCES = ("3.x", "4.0")


def with_pair_variance(an: EmvaAnalysis, pair_variance: str) -> EmvaAnalysis:
    """``an`` with its Release 3.0 and 3.1 sets evaluated from the pair variance
    ``pair_variance``: "3.x" (as they are: the variance of a pair without the mean-difference
    term, which Release 4.0 added -- 4.0 Linear Appendix E.1 item 4) or "4.0" (4.0 Linear
    Eq. 18, the two images' mean difference removed: what the reference implementation
    ``emva1288`` 1.0.2 computes for every release)."""
    if pair_variance == "3.x":
        return an
    if pair_variance != "4.0":
        raise ValueError(f"pair variance {pair_variance!r} is not one of {PAIR_VARIANCES}")
    import numpy as np

    from ares.analysis.emva.release3 import emva1288_results

    td = dataclasses.replace(an.emva.temporal, s2_y=np.array([b.var for b in an.bright]),
                             s2_ydark=np.array([d.var for d in an.dark]))
    sb, sd = an.spatial or (None, None)
    res = emva1288_results(td, sb, sd)
    inp = an.inp
    r31 = release31(res, inp.stack_bright if inp is not None else None, inp.stack_dark if inp is not None else None)
    return dataclasses.replace(an, emva=res, release31=r31)


def release31(res, stack_b, stack_d) -> dict:
    """Release 3.1 = the 3.0 set with DSNU1288/PRNU1288 from 5x5-box high-passed stacks,
    the spatial standard deviation divided by 0.96 (Linear 4.0 Appendix C.5, Eqs. 84 - 86)."""
    from ares.analysis.spatial.nonuniformity import std_estimate
    from ares.analysis.spatial.pattern_se import stack_variance_se
    from ares.analysis.stats.estimate import Estimate

    K = res.values["K"]
    out = {k: e for k, e in res.values.items()}

    def s2(st):  # Eq. 86: the filter keeps 0.96^2 of a white pattern and of the temporal residual
        return st.highpassed_var("3.1") / 0.96**2 - st.temporal_var / st.L

    if stack_b is None or stack_d is None:
        why = "needs a bright and a dark stack of images for the 5x5 high-pass (Appendix C.5); the data set has none"
        out["DSNU1288"], out["PRNU1288"] = Estimate.na(why, "e-"), Estimate.na(why, "%")
        return out
    try:
        d2, b2 = s2(stack_d), s2(stack_b)
    except ValueError as exc:  # smaller than the 5x5 filter
        out["DSNU1288"] = Estimate.na(str(exc), "e-")
        out["PRNU1288"] = Estimate.na(str(exc), "%")
        return out
    sig = float(stack_b.mean_image.mean() - stack_d.mean_image.mean())

    def se(st):  # the measurement error of this sensor's pattern, as Release 3.0's (the temporal noise left
        # in the average over its pixels; the 5x5 filter's correlation of neighbours not modelled)
        return stack_variance_se(s2(st), st.temporal_var, st.L, st.mean_image.size)

    out["DSNU1288"] = (std_estimate(d2, se(stack_d), 1.0 / K.value, K.se / K.value, "e-",
                                    "s_y.dark after the 5x5 high-pass / 0.96, / K (Release 3.1, Appendix C.5)")
                       if d2 > 0 else Estimate.na("no dark spatial variance above the temporal residual", "e-"))
    out["PRNU1288"] = (std_estimate(b2 - d2, math.hypot(se(stack_b), se(stack_d)), 100.0 / sig, 0.0, "%",
                                    "sqrt(s2_y.50 - s2_y.dark) after the 5x5 high-pass / 0.96, / (mu_y.50 - mu_y.dark) "
                                    "(Release 3.1)")
                       if b2 > d2 and sig > 0 else Estimate.na("no spatial signal variance above dark", "%"))
    return out
