"""``ares photon-counting``: gain and read noise of a deep sub-electron sensor from the
photon-counting histogram of a user's own low-light stack.

    ares photon-counting FRAMES... --dark FRAMES... [--roi X,Y,W,H] [--json] [--pdf FILE]

The frames are read as ``ares analyze`` reads them (PNG/TIFF, folders, .npy/.npz, HDF5
``file.h5:/dataset``; ``ares.hardware.stackfiles``): a low-light stack (0.05-2 e-/pixel)
and, after ``--dark``, the dark stack of the same exposure. The histogram of the integer
codes is fitted with Poisson-weighted Gaussians, the dark histogram jointly (same offset
and read noise): ``ares.analysis.optics.photon_counting`` (Starkey & Fossum 2016). Beside
it, the photon-transfer estimate of the same stacks (light and dark temporal variances).
Every figure with its SE, or "not available" and why (peaks merged, model does not fit).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ares.errors import InputError

NAME = "photon-counting"
HELP = "gain and read noise from the photon-counting histogram of a low-light stack (and its dark)"


def add_arguments(p) -> None:
    p.add_argument("files", nargs="*", help="low-light stack files (PNG/TIFF, folders, .npy, .npz, .h5:/dataset)")
    p.add_argument("--flat", nargs="+", default=None, metavar="FILE",
                   help="low-light stack files (the same as the positional files; cannot be swallowed by --dark)")
    p.add_argument("--dark", nargs="+", default=None, metavar="FILE",
                   help="dark stack files, same exposure (fitted jointly: offset and read noise)")
    p.add_argument("--roi", default=None, metavar="X,Y,W,H", help="region of analysis (default: full frame)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--pdf", default=None, metavar="FILE", help="write the histogram page to a PDF")


class _Codes:
    """The integer-code histogram of a stack, frame by frame."""

    def __init__(self, what: str):
        self.what, self.lo, self.h = what, None, None

    def __call__(self, _k, frame) -> None:
        f = np.asarray(frame)
        v = np.rint(f).astype(np.int64) if not np.issubdtype(f.dtype, np.integer) else f.astype(np.int64)
        if not np.issubdtype(f.dtype, np.integer) and not np.array_equal(v, f):
            raise InputError(f"the {self.what} frames hold non-integer values: photon counting needs the ADC's codes")
        lo, hi = int(v.min()), int(v.max())
        if self.lo is None:
            self.lo, self.h = lo, np.zeros(hi - lo + 1, np.int64)
        if lo < self.lo:
            self.h, self.lo = np.concatenate([np.zeros(self.lo - lo, np.int64), self.h]), lo
        if hi - self.lo + 1 > self.h.size:
            self.h = np.concatenate([self.h, np.zeros(hi - self.lo + 1 - self.h.size, np.int64)])
        if self.h.size > 200000:
            raise InputError(f"the {self.what} values span {self.h.size} codes: photon counting needs a low-light stack")
        self.h += np.bincount((v - self.lo).ravel(), minlength=self.h.size)[: self.h.size]

    def codes(self):
        return np.arange(self.lo, self.lo + self.h.size)


def measure(files, dark_files, roi) -> dict:
    """The fit, the photon-transfer estimate, and the stacks' sizes."""
    from ares.analysis.optics.photon_counting import fit_code_histogram, photon_transfer_levels
    from ares.commands.analyze import accumulate_files

    lh = _Codes("light")
    light = accumulate_files(files, roi, "light", on_frame=lh)
    kw, pt, dark = {}, None, None
    if dark_files:
        dh = _Codes("dark")
        dark = accumulate_files(dark_files, roi, "dark", on_frame=dh)
        if dark.shape != light.shape:
            raise InputError(f"dark frames {dark.shape} and light frames {light.shape} differ in shape")
        kw = {"dark_codes": dh.codes(), "dark_counts": dh.h}
        if light.n_frames > 1 and dark.n_frames > 1:
            pt = photon_transfer_levels(float(light.mean_map().mean()), float(light.temporal_var_map().mean()),
                                        light.n_frames, float(dark.mean_map().mean()),
                                        float(dark.temporal_var_map().mean()), dark.n_frames,
                                        int(np.prod(light.shape)))
    fit = fit_code_histogram(lh.codes(), lh.h, **kw)
    return {"fit": fit, "photon_transfer": pt, "frames": light.n_frames,
            "dark_values": int(dh.h.sum()) if dark_files else 0,
            "dark_frames": dark.n_frames if dark is not None else 0, "shape": list(light.shape)}


NAMES = {"K": "gain K", "read_noise_e": "read noise", "mean_e": "mean charge", "offset_dn": "offset"}


def run(args) -> int:
    from ares.analysis.optics.photon_counting import result_dict
    from ares.commands.analyze import input_files

    files = input_files(args)
    m = measure(files, args.dark, args.roi)
    res = result_dict(m["fit"], m["photon_transfer"])
    frames = max(m["frames"], m["dark_frames"])
    for k in ("K", "read_noise_e"):  # the values a precise enough result needs, as frames of this stack
        if "needs_values" in res[k]:
            n = float(np.sum(m["fit"]["hist_counts"])) + m["dark_values"]
            res[k]["needs_frames"] = int(np.ceil(frames * res[k]["needs_values"] / max(n, 1)))
    if args.pdf:
        import matplotlib

        from ares.report import plots
        from ares.report.photon_counting_page import photon_counting_page

        with matplotlib.rc_context(plots.RC):
            plots.save_pdf([photon_counting_page("user stack", res)], Path(args.pdf),
                           "ARES photon counting", "ares photon-counting")
    if args.json:
        out = {k: v for k, v in res.items()}
        out["_meta"] = {"files": [str(f) for f in files], "dark_files": [str(f) for f in args.dark or []],
                        "frames": m["frames"], "dark_frames": m["dark_frames"], "shape": m["shape"], "roi": args.roi}
        print(json.dumps(out, indent=2, allow_nan=False))
        return 0
    R, C = m["shape"]
    print(f"ares photon-counting: {m['frames']} frames of {R} rows x {C} columns"
          + (f", {m['dark_frames']} dark frames" if m["dark_frames"] else ", no dark stack")
          + (f", region {args.roi}" if args.roi else ""))
    fit, pt = m["fit"], m["photon_transfer"] or {}
    for k, label in NAMES.items():
        e = fit[k]
        line = f"  {label:<12} {e.text(with_reason=True)}"
        if k in pt:
            line += f"   (photon transfer: {pt[k].text(with_reason=True)})"
        print(line)
        if "precision" in res[k]:
            print(f"  {'':<12} {res[k]['verdict']}: {res[k]['precision']}; >= {res[k]['needs_frames']} frames "
                  "(light and dark each) of this size")
    if "chi2_ndf" in fit:
        print(f"  histogram scatter about the fit: {fit['chi2_ndf']:.3g}x its Poisson expectation")
    first = next((e for e in (fit[k] for k in NAMES) if e.available), None)
    if first is not None and first.note:
        print(f"  ({first.note})")
    return 0
