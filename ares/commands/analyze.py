"""``ares analyze``: noise decomposition of recorded frame stacks.

    ares analyze FLAT_OR_DARK_FILES... [--dark DARK_FILES...] [--roi X,Y,W,H] [--gain G]
                 [--illumination highpass|surface|none] [--json]
    ares analyze --flat FLAT_FILES... --dark DARK_FILES... [...]

A file list after ``--dark`` runs to the next option, so the flat files go first or
after ``--flat`` (a command line whose list ``--dark`` took whole is refused, saying so).
The gain takes its unit (``0.28DN/e-``, ``3.57e-/DN``, ``70uV/e-`` with ``--adc-lsb-uv``).

Without ``--dark`` the files are one stack analysed with the dark (offset/noise) model
and the gain components are reported as not available. With ``--dark`` the files are
the flat (illuminated) stack and the gain part runs too. Files: PNG/TIFF images,
folders of them, .npy/.npz, or HDF5 ``file.h5:/dataset`` (ares/hardware/stackfiles.py).
"""

from __future__ import annotations

import json

from ares.commands.argtypes import gain, positive
from ares.errors import InputError

# the analysis is imported when the command runs, not when `ares --help` builds its parser

NAME = "analyze"
HELP = "noise decomposition (13 components + frame-global) of recorded frame stacks"



def add_arguments(p) -> None:
    p.add_argument("files", nargs="*", help="stack files (flat stack when --dark is given)")
    p.add_argument("--flat", nargs="+", default=None, metavar="FILE",
                   help="flat stack files (the same as the positional files; cannot be swallowed by --dark)")
    p.add_argument("--dark", nargs="+", default=None, metavar="FILE", help="dark stack files")
    p.add_argument("--roi", default=None, metavar="X,Y,W,H", help="region of analysis (default: full frame)")
    p.add_argument("--gain", type=gain, default=None, metavar="K",
                   help="system gain with its unit: 0.28DN/e-, 3.57e-/DN or 70uV/e- (needs --adc-lsb-uv); "
                        "a bare number is DN/e- (enables the Poisson check)")
    p.add_argument("--adc-lsb-uv", type=positive, default=None, metavar="UV",
                   help="the ADC step in uV (to turn a gain in uV/e- into DN/e-)")
    p.add_argument("--illumination", choices=("highpass", "surface", "none"), default="highpass",
                   help="removal of smooth illumination before the gain non-uniformity (default: highpass, EMVA 4.0)")
    p.add_argument("--bits", type=int, default=None,
                   help="ADC bits: its full scale 2^N - 1 is the clip level (default: the data type's maximum, or "
                        "the stack's own maximum when it is 2^N - 1 held by pixels in every frame)")
    p.add_argument("--json", action="store_true", help="print JSON keyed by component name")


def accumulate_files(specs, roi_text, what, on_frame=None, clip=None, mask=None):
    """The stack's accumulator (``on_frame(k, frame)`` sees each frame: the GUI's Input
    Images preview, which analyses files exactly as this command does). ``clip``: a
    ``ClipScan`` fed the same frames; ``mask``: the pixels to exclude (a masked accumulator)."""
    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.analysis.noise.masked import MaskedStackAccumulator
    from ares.analysis.noise.regions import parse_roi, region_selection
    from ares.hardware.stackfiles import iter_frames

    acc = sel = None
    for k, frame in enumerate(iter_frames(specs)):
        if acc is None:
            sel = region_selection(parse_roi(roi_text), frame.shape) if roi_text else None
            shape = sel.shape(frame.shape) if sel else frame.shape
            acc = StackAccumulator(shape) if mask is None else MaskedStackAccumulator(shape, mask)
        part = sel(frame) if sel else frame
        acc.add(part)
        if clip is not None:
            clip.add(part)
        if on_frame is not None:
            on_frame(k, part)
    if acc is None:
        raise InputError(f"{specs[0]}: the {what} stack holds no frames")
    return acc



# ares analyze decomposes every pixel: the figures are the "all pixels" ones of ares run
NO_MASK_NOTE = ("All pixels: no defect mask is applied (ares run leaves out the defect pixels it finds); a few "
                "stuck, hot or noisy pixels can dominate Ps and Pt -- `ares defects --dark FILES` lists them.")


def input_files(args) -> list:
    """The flat (or only) stack's files: the positional ones and ``--flat``'s, refused when
    there are none -- with ``--dark`` given, because its list took them."""
    files = list(args.files or []) + list(args.flat or [])
    if files:
        return files
    if args.dark:
        raise InputError(f"no flat files: --dark took all {len(args.dark)} file(s) after it; put the flat "
                         "files before --dark or after --flat")
    raise InputError("no input files: give the stack's files (or --flat FILES... with --dark FILES...)")


def _clip_scan(args):
    from ares.analysis.noise.clipping import ClipScan, adc_full_scale

    if args.bits is None:
        return ClipScan()
    if not 1 <= args.bits <= 32:
        raise InputError(f"--bits {args.bits}: give the ADC's bits, 1 to 32")
    return ClipScan(adc_full_scale(args.bits), f"--bits {args.bits}")


def analysis(args):
    """``(StackAnalysis, main accumulator, clipping summary, reason none can be made)``: the
    stacks read once with their clipped pixels found; a partly clipped stack read again over
    its unclipped pixels (``ares.analysis.noise.clipping``)."""
    from ares.analysis.noise.clipping import combine, too_clipped
    from ares.analysis.noise.decompose import StackAnalysis

    files = input_files(args)
    k = args.gain.dn_per_e(args.adc_lsb_uv) if args.gain is not None else None
    clip = _clip_scan(args)
    main = accumulate_files(files, args.roi, "flat" if args.dark else "input", clip=clip)
    dark = None
    if args.dark:
        dclip = _clip_scan(args)
        dark = accumulate_files(args.dark, args.roi, "dark", clip=dclip)
        if dark.shape != main.shape:
            raise InputError(f"dark frames {dark.shape} and flat frames {main.shape} differ in shape")
    s = clip.summary() if dark is None else combine(clip.summary(), dclip.summary())
    why = too_clipped(s) if s["pixels"] else None
    if s["pixels"] and why is None:  # the unclipped pixels only
        main = accumulate_files(files, args.roi, "flat" if args.dark else "input", mask=s["mask"])
        if dark is not None:
            dark = accumulate_files(args.dark, args.roi, "dark", mask=s["mask"])
    if dark is not None:
        an = StackAnalysis(dark, main, gain=k, illumination=args.illumination)
    else:
        an = StackAnalysis(main, gain=k)
    return an, main, s, why


def run(args) -> int:
    from ares.analysis.noise.clipping import clipped_na, describe, flag_clipped
    from ares.analysis.noise.decompose import COMPONENT_NAMES, UNITS_NOTE
    from ares.analysis.stats.physical import variances_in_range

    an, main, clip, why = analysis(args)
    k = args.gain.dn_per_e(args.adc_lsb_uv) if args.gain is not None else None
    if why:
        comps = clipped_na({n: e for n, e in an.gain_components.items() if n in COMPONENT_NAMES} |
                           {n: e for n, e in an.dark_components.items()}, why)
        extra = clipped_na(an.extras(), why)
        fsc = clipped_na(an.flat_stack_components, why) if args.dark else None
    else:
        comps, extra = an.components(), an.extras()
        fsc = variances_in_range(an.flat_stack_components) if args.dark else None
        if clip["pixels"]:
            comps, extra = flag_clipped(comps, clip), flag_clipped(extra, clip)
            fsc = flag_clipped(fsc, clip) if fsc is not None else None
    clip_json = {key: clip[key] for key in ("pixels", "at_top", "at_zero", "total", "top_dn", "top_source")}
    clip_json["excluded"] = bool(clip["pixels"]) and not why
    if args.json:
        out = {k: comps[k].to_dict() for k in COMPONENT_NAMES}
        for k, e in extra.items():
            out[k] = e.to_dict()
        if args.dark:
            out["_flat_stack"] = {k: e.to_dict() for k, e in fsc.items()}
        out["_meta"] = {
            "units": UNITS_NOTE, "pixels": NO_MASK_NOTE,
            "frames": {"dark" if args.dark else "input": an.dark.n_frames, **({"flat": main.n_frames} if args.dark else {})},
            "shape": list(main.shape),
            "roi": args.roi,
            "clipping": clip_json | ({"note": describe(clip)} if clip["pixels"] else {}),
        }
        print(json.dumps(out, indent=2))
        return 0
    R, C = main.shape
    head = f"{an.dark.n_frames} dark frames" if args.dark else f"{main.n_frames} frames"
    if args.dark:
        head += f", {main.n_frames} flat frames"
    print(f"ares analyze: {head} of {R} rows x {C} columns" + (f", region {args.roi}" if args.roi else ""))
    if clip["pixels"]:
        print(f"  CLIPPED: {describe(clip)}; " + ("no figure can be made." if why else
                                                   "they are excluded from every figure below."))
    from ares.report.tables import component_label, component_text

    # the same rendering as `ares run` and the report: % rms for the gain spreads, the SE's
    # digits, a variance below 0 as a bound or "the model does not fit" (report/tables.py)
    elec = an.in_electrons() if not why and (k is not None or comps["G"].available) else {}
    for name in list(COMPONENT_NAMES) + list(extra):
        e = comps.get(name) or extra[name]
        line = f"  {name:<14} {component_text(name, e.to_dict()):<34} {component_label(name)}"
        if name in elec and name != "o" and elec[name].available:
            line += f"; in electrons {component_text(name, elec[name].to_dict())}"
        if e.available and e.note:  # how it was made, or why it has no SE (n/a's reason is in the text)
            line += f"  ({e.note})"
        print(line)
    if args.dark:
        fg = fsc["frame_global"]  # as --json states it
        print(f"  {'':<14} {component_text('frame_global', fg.to_dict()):<34} flat stack frame-global "
              "(light-source flicker + dark frame-global)")
    print("Variances in DN^2 (e-^2 in electrons); Cg, Rg, Pg as % rms of the relative gain (--json: their "
          "relative variances); Pt includes the 1/12 DN^2 quantization noise.")
    print(NO_MASK_NOTE)
    return 0
