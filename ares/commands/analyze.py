"""``ares analyze``: noise decomposition of recorded frame stacks.

    ares analyze FLAT_OR_DARK_FILES... [--dark DARK_FILES...] [--roi X,Y,W,H] [--gain G]
                 [--illumination highpass|surface|none] [--json]

Without ``--dark`` the files are one stack analysed with the dark (offset/noise) model
and the gain components are reported as not available. With ``--dark`` the files are
the flat (illuminated) stack and the gain part runs too. Files: PNG/TIFF images,
folders of them, .npy/.npz, or HDF5 ``file.h5:/dataset`` (ares/hardware/stackfiles.py).
"""

from __future__ import annotations

import json
import math

from ares import labels
from ares.commands.argtypes import gain
from ares.errors import InputError

# the analysis is imported when the command runs, not when `ares --help` builds its parser

NAME = "analyze"
HELP = "noise decomposition (13 components + frame-global) of recorded frame stacks"

_DESCR = {**labels.COMPONENTS, **{k: labels.COMPONENTS[k] + " (rel. var)" for k in ("Cg", "Rg", "Pg")},
          "poisson_ratio": "Poisson check (~1)"}


def add_arguments(p) -> None:
    p.add_argument("files", nargs="+", help="stack files (flat stack when --dark is given)")
    p.add_argument("--dark", nargs="+", default=None, metavar="FILE", help="dark stack files")
    p.add_argument("--roi", default=None, metavar="X,Y,W,H", help="region of analysis (default: full frame)")
    p.add_argument("--gain", type=gain, default=None, help="conversion gain in DN/e- (enables the Poisson check)")
    p.add_argument("--illumination", choices=("highpass", "surface", "none"), default="highpass",
                   help="removal of smooth illumination before the gain non-uniformity (default: highpass, EMVA 4.0)")
    p.add_argument("--json", action="store_true", help="print JSON keyed by component name")


def accumulate_files(specs, roi_text, what, on_frame=None):
    """The stack's accumulator (``on_frame(k, frame)`` sees each frame: the GUI's Input
    Images preview, which analyses files exactly as this command does)."""
    from ares.analysis.accumulate import StackAccumulator
    from ares.analysis.regions import parse_roi, region_selection
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



def _fmt(v: float) -> str:
    if v is None or not math.isfinite(v):
        return "n/a"
    return f"{v:.6g}"


def run(args) -> int:
    from ares.analysis.decompose import COMPONENT_NAMES, UNITS_NOTE, StackAnalysis
    from ares.analysis.physical import variances_in_range

    main = accumulate_files(args.files, args.roi, "flat" if args.dark else "input")
    if args.dark:
        dark = accumulate_files(args.dark, args.roi, "dark")
        if dark.shape != main.shape:
            raise InputError(f"dark frames {dark.shape} and flat frames {main.shape} differ in shape")
        an = StackAnalysis(dark, main, gain=args.gain, illumination=args.illumination)
    else:
        an = StackAnalysis(main, gain=args.gain)
    comps = an.components()
    extra = an.extras()
    if args.json:
        out = {k: comps[k].to_dict() for k in COMPONENT_NAMES}
        for k, e in extra.items():
            out[k] = e.to_dict()
        if args.dark:
            out["_flat_stack"] = {k: e.to_dict() for k, e in variances_in_range(an.flat_stack_components).items()}
        out["_meta"] = {
            "units": UNITS_NOTE,
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
    elec = an.in_electrons() if (args.gain is not None or comps["G"].available) else {}
    print(f"{'component':14s} {'':31s} {'value':>12s} {'std. error':>12s}  {'unit':6s}" + ("   in electrons" if elec else ""))
    for k in list(COMPONENT_NAMES) + list(extra):
        e = comps.get(k) or extra[k]
        line = f"{k:14s} {_DESCR.get(k, ''):31s} {_fmt(e.value):>12s} {_fmt(e.se):>12s}  {e.unit:6s}"
        if k in elec and k != "o" and elec[k].available:
            line += f"   {_fmt(elec[k].value)} ± {_fmt(elec[k].se)} {elec[k].unit}"
        if e.note:
            line += f"  ({e.note})"
        print(line)
    if args.dark:
        fg = an.flat_stack_components["frame_global"]
        print(f"{'':14s} {'flat stack frame-global':31s} {_fmt(fg.value):>12s} {_fmt(fg.se):>12s}  {fg.unit:6s}"
              "  (light-source flicker + dark frame-global)")
    print(f"Units: {UNITS_NOTE}. Pt includes the 1/12 DN^2 quantization noise.")
    return 0
