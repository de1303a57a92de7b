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
    p.add_argument("--json", action="store_true", help="print JSON keyed by component name")


def accumulate_files(specs, roi_text, what, on_frame=None):
    """The stack's accumulator (``on_frame(k, frame)`` sees each frame: the GUI's Input
    Images preview, which analyses files exactly as this command does)."""
    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.analysis.noise.regions import parse_roi, region_selection
    from ares.hardware.stackfiles import iter_frames

    acc = sel = None
    for k, frame in enumerate(iter_frames(specs)):
        if acc is None:
            sel = region_selection(parse_roi(roi_text), frame.shape) if roi_text else None
            shape = sel.shape(frame.shape) if sel else frame.shape
            acc = StackAccumulator(shape)
        part = sel(frame) if sel else frame
        acc.add(part)
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


def run(args) -> int:
    from ares.analysis.noise.decompose import COMPONENT_NAMES, UNITS_NOTE, StackAnalysis
    from ares.analysis.stats.physical import variances_in_range

    files = input_files(args)
    k = args.gain.dn_per_e(args.adc_lsb_uv) if args.gain is not None else None
    main = accumulate_files(files, args.roi, "flat" if args.dark else "input")
    if args.dark:
        dark = accumulate_files(args.dark, args.roi, "dark")
        if dark.shape != main.shape:
            raise InputError(f"dark frames {dark.shape} and flat frames {main.shape} differ in shape")
        an = StackAnalysis(dark, main, gain=k, illumination=args.illumination)
    else:
        an = StackAnalysis(main, gain=k)
    comps = an.components()
    extra = an.extras()
    if args.json:
        out = {k: comps[k].to_dict() for k in COMPONENT_NAMES}
        for k, e in extra.items():
            out[k] = e.to_dict()
        if args.dark:
            out["_flat_stack"] = {k: e.to_dict() for k, e in variances_in_range(an.flat_stack_components).items()}
        out["_meta"] = {
            "units": UNITS_NOTE, "pixels": NO_MASK_NOTE,
            "frames": {"dark" if args.dark else "input": an.dark.n_frames, **({"flat": main.n_frames} if args.dark else {})},
            "shape": list(main.shape),
            "roi": args.roi,
        }
        print(json.dumps(out, indent=2))
        return 0
    R, C = main.shape
    head = f"{an.dark.n_frames} dark frames" if args.dark else f"{main.n_frames} frames"
    if args.dark:
        head += f", {main.n_frames} flat frames"
    print(f"ares analyze: {head} of {R} rows x {C} columns" + (f", region {args.roi}" if args.roi else ""))
    from ares.report.tables import component_label, component_text

    # the same rendering as `ares run` and the report: % rms for the gain spreads, the SE's
    # digits, a variance below 0 as a bound or "the model does not fit" (report/tables.py)
    elec = an.in_electrons() if (k is not None or comps["G"].available) else {}
    for name in list(COMPONENT_NAMES) + list(extra):
        e = comps.get(name) or extra[name]
        line = f"  {name:<14} {component_text(name, e.to_dict()):<34} {component_label(name)}"
        if name in elec and name != "o" and elec[name].available:
            line += f"; in electrons {component_text(name, elec[name].to_dict())}"
        if e.available and e.note:  # how it was made, or why it has no SE (n/a's reason is in the text)
            line += f"  ({e.note})"
        print(line)
    if args.dark:
        fg = variances_in_range(an.flat_stack_components)["frame_global"]  # as --json states it
        print(f"  {'':<14} {component_text('frame_global', fg.to_dict()):<34} flat stack frame-global "
              "(light-source flicker + dark frame-global)")
    print("Variances in DN^2 (e-^2 in electrons); Cg, Rg, Pg as % rms of the relative gain (--json: their "
          "relative variances); Pt includes the 1/12 DN^2 quantization noise.")
    print(NO_MASK_NOTE)
    return 0
