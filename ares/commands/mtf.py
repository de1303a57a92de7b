"""``ares mtf``: the slanted-edge MTF (ISO 12233 e-SFR) of a user's own edge images.

    ares mtf IMAGES... [--roi X,Y,W,H] [--bayer PATTERN] [--bits N] [--esf-half-width PX] [--json] [--pdf FILE]

The images (PNG/TIFF, .npy/.npz, .h5:/dataset; several are averaged as one stack) are read
by ``ares.hardware.stackfiles``; the analysis is ``ares.analysis.optics.mtf`` (per Bayer channel
with ``--bayer``, each channel's own pixels). Every figure with its SE, or "not available"
and why (edge angle outside 2-22 deg, too little contrast, clipping). ``--esf-half-width``
adds the option (the ESF within that many pixels of the edge, not the standard) beside the
standard's result, labelled; it never replaces it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ares.errors import InputError

NAME = "mtf"
HELP = "slanted-edge MTF (ISO 12233 e-SFR): MTF50 and MTF at Nyquist of edge images"


def add_arguments(p) -> None:
    p.add_argument("images", nargs="+", help="edge image files (PNG/TIFF, .npy, .npz, .h5:/dataset); averaged")
    p.add_argument("--roi", default=None, metavar="X,Y,W,H", help="region holding the edge (default: whole image)")
    p.add_argument("--bayer", default=None, metavar="PATTERN", help="raw Bayer mosaic: RGGB, GRBG, GBRG or BGGR")
    p.add_argument("--bits", type=int, default=None,
                   help="ADC bits (the full-scale code for the clipping check; default: the data type's)")
    p.add_argument("--esf-half-width", type=float, default=None, metavar="PX",
                   help="also report the option: the ESF within PX pixels of the edge only (e.g. 16; less noise "
                        "in the LSF window, not the standard), beside the standard result")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--pdf", default=None, metavar="FILE", help="write the MTF page to a PDF")


def _roi(spec: str, shape) -> tuple[slice, slice]:
    try:
        x, y, w, h = (int(v) for v in spec.split(","))
    except ValueError:
        raise InputError(f"--roi {spec!r}: give four integers X,Y,W,H") from None
    if w < 16 or h < 16 or x < 0 or y < 0 or x + w > shape[1] or y + h > shape[0]:
        raise InputError(f"--roi {spec!r} is not a region of at least 16x16 pixels inside the {shape[1]}x{shape[0]} image")
    return slice(y, y + h), slice(x, x + w)


def _write_pdf(channels: dict, path: Path, title: str) -> None:
    import matplotlib

    from ares.report import plots
    from ares.report.mtf_page import mtf_page

    with matplotlib.rc_context(plots.RC):
        plots.save_pdf([mtf_page(channels, "Slanted-edge MTF", title)], path, f"ARES MTF {title}", "ares mtf")


def run(args) -> int:
    from ares.analysis.optics.mtf import CHANNEL_NAMES, channels_dict, sfr_channels
    from ares.protocol.scan import ANALYSIS_OPTIONS
    from ares.hardware.stackfiles import iter_frames

    from ares.safefile import output_file, writing

    if args.pdf:  # before the work (ares.safefile)
        output_file(args.pdf, "--pdf")
    if args.bayer is not None and args.bayer.upper() not in CHANNEL_NAMES:
        raise InputError(f"--bayer {args.bayer!r}: use one of {', '.join(CHANNEL_NAMES)}")
    hw, hw_min = args.esf_half_width, ANALYSIS_OPTIONS["mtf"]["esf_half_width"]
    if hw is not None and not (np.isfinite(hw) and hw >= hw_min):
        raise InputError(f"--esf-half-width {hw:g}: give a number of pixels of at least {hw_min:g}")
    total, n, dtype = None, 0, None
    for frame in iter_frames(args.images):
        total = frame.astype(np.float64) if total is None else total + frame
        n, dtype = n + 1, frame.dtype
    if total is None:
        raise InputError("the images hold no frames")
    img = total / n
    if args.roi:
        img = img[_roi(args.roi, img.shape)]
    if args.bits is not None:
        if not 1 <= args.bits <= 32:
            raise InputError(f"--bits {args.bits}: give the ADC's bits, 1 to 32")
        full = float(2 ** args.bits - 1)
    else:
        full = float(np.iinfo(dtype).max) if np.issubdtype(dtype, np.integer) else None
    res = sfr_channels(img, args.bayer, max_code=full)
    opt = sfr_channels(img, args.bayer, max_code=full, esf_half_width=hw) if hw is not None else None
    out = {"images": [str(p) for p in args.images], "frames": n, "roi": args.roi,
           "channels": channels_dict(res, opt, hw, curve=args.json or bool(args.pdf))}
    if args.pdf:
        with writing(args.pdf):
            _write_pdf(out["channels"], Path(args.pdf), ", ".join(out["images"])[:90])
    if args.json:
        print(json.dumps(out, indent=2, allow_nan=False))
        return 0
    for name, r in res.items():
        print(f"{name}: MTF50 {r.mtf50.text(with_reason=True)}, MTF at Nyquist ({r.nyquist:g} cy/px) "
              f"{r.mtf_nyquist.text(with_reason=True)}, edge angle {r.angle_deg.text(with_reason=True)}")
        if opt is not None:
            o = opt[name]
            print(f"{name}, option esf_half_width={hw:g} px (not the standard): MTF50 {o.mtf50.text(with_reason=True)}, "
                  f"MTF at Nyquist {o.mtf_nyquist.text(with_reason=True)}")
    return 0
