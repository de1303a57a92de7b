"""``ares defects``: defective pixels, lines and clusters of recorded dark (and flat) stacks.

Each ``--dark FILES...`` (or ``--flat``) occurrence is one level: its files are read in
order as one stack, streamed frame by frame (memory does not grow with the number of
frames). Files as for ``ares analyze`` (``ares.hardware.stackfiles``): PNG/TIFF images or
folders of them, ``.npy``, ``.npz`` (every array, or ``file.npz:name``), HDF5
``file.h5:/dataset``. Prints counts per class, bad lines, clusters and the pass/fail of
any ``max_*`` limits (``--set max_hot=10``; a failed limit exits 4); ``--json`` prints
the full result; ``--mask-png``/``--mask-h5`` write the per-pixel class bitmask (bits in
the JSON ``mask_bits``); ``--bayer`` classifies each colour channel (Bayer phase)
against its own statistics.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ares.commands.argtypes import gain, non_negative, positive
from ares.errors import InputError, LimitsFailed

# numpy and the analysis are imported when the command runs (`ares --help` stays light)

#: the four Bayer phases as (row slice, column slice), named by (row % 2, column % 2)
BAYER_PHASES = {f"{r}{c}": (slice(r, None, 2), slice(c, None, 2)) for r in (0, 1) for c in (0, 1)}

NAME = "defects"
HELP = "defective pixel identification and counting on recorded dark/flat stacks"


def add_arguments(p) -> None:
    p.add_argument("--dark", nargs="+", action="append", required=True, metavar="FILE",
                   help="dark frames/stacks of one level (repeat the option for more levels)")
    p.add_argument("--flat", nargs="+", action="append", default=None, metavar="FILE",
                   help="illuminated frames/stacks of one level (repeatable)")
    p.add_argument("--gain", type=gain, default=None, metavar="K",
                   help="system gain with its unit: 0.28DN/e-, 3.57e-/DN or 70uV/e- (needs --adc-lsb-uv); a bare number is DN/e-")
    p.add_argument("--adc-lsb-uv", type=positive, default=None, metavar="UV",
                   help="the ADC step in uV (to turn a gain in uV/e- into DN/e-)")
    p.add_argument("--exposure", type=non_negative, nargs="+", default=None, metavar="S",
                   help="exposure time(s) in s: one for all levels, or one per dark level")
    p.add_argument("--flat-exposure", type=non_negative, nargs="+", default=None, metavar="S",
                   help="exposure time(s) of the flat levels (default: --exposure)")
    p.add_argument("--set", dest="settings", action="append", default=[], metavar="NAME=VALUE",
                   help="override a threshold or limit, e.g. --set hot_e_per_s=5 --set max_hot=100")
    p.add_argument("--bayer", action="store_true",
                   help="classify each Bayer phase (colour channel) separately against its own statistics")
    p.add_argument("--json", action="store_true", help="print the full result as JSON")
    p.add_argument("--mask-png", default=None, metavar="FILE", help="write the class bitmask as a 16-bit PNG")
    p.add_argument("--mask-h5", default=None, metavar="FILE", help="write the class bitmask to an HDF5 file")


def level_stats(paths: list[str], exposure_s: float | None, what: str) -> PixelStats:
    """Per-pixel mean and temporal variance of one level, streamed frame by frame from its
    files (memory independent of the number of frames)."""
    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.analysis.defects import PixelStats
    from ares.hardware.stackfiles import iter_frames

    acc = None
    for frame in iter_frames(paths):
        if acc is None:
            acc = StackAccumulator(frame.shape)
        acc.add(frame)
    if acc is None or acc.n_frames < 2:
        raise InputError(f"{paths[0]}: each {what} level needs at least 2 frames for a temporal variance")
    return PixelStats.from_accumulator(acc, exposure_s)


def candidate_series(paths: list[str], rows: np.ndarray, cols: np.ndarray) -> SeriesCollector:
    """Pass 2: the time series of the RTS candidates (rows, cols), re-read from the files."""
    from ares.analysis.defects import SeriesCollector
    from ares.hardware.stackfiles import iter_frames

    col = SeriesCollector(rows, cols)
    for frame in iter_frames(paths):
        col.add(frame)
    return col


def _global_candidates(results: dict, regions) -> tuple[np.ndarray, np.ndarray]:
    """The RTS candidates of every region in full-frame coordinates."""
    import numpy as np

    rr, cc = [], []
    for name, res in results.items():
        r, c = res.rts_candidates
        rs, cs = regions[name] if regions else (slice(None), slice(None))
        r0, rstep = rs.start or 0, rs.step or 1
        c0, cstep = cs.start or 0, cs.step or 1
        rr.append(r0 + rstep * np.asarray(r, np.intp))
        cc.append(c0 + cstep * np.asarray(c, np.intp))
    return np.concatenate(rr), np.concatenate(cc)


def write_mask_png(path: str | Path, mask: np.ndarray) -> None:
    """The uint16 class bitmask as a lossless 16-bit grayscale PNG (values are the bits)."""
    import numpy as np
    from PIL import Image

    try:
        Image.fromarray(np.ascontiguousarray(mask, dtype=np.uint16)).save(Path(path), format="PNG")
    except OSError as exc:
        raise InputError(f"{path}: cannot write the mask PNG ({exc})") from None


def write_mask_h5(path: str | Path, mask: np.ndarray, results: dict[str, DefectResult]) -> None:
    """Dataset ``defects/mask`` (uint16 bits, attributes ``bit_<class>``) and the counts as JSON."""
    from ares.analysis.defects import BITS
    import h5py

    try:
        with h5py.File(path, "w") as f:
            ds = f.create_dataset("defects/mask", data=mask, compression="gzip")
            for name, bit in BITS.items():
                ds.attrs[f"bit_{name}"] = bit
            f["defects"].attrs["counts"] = json.dumps({k: r.counts for k, r in results.items()})
    except OSError as exc:
        raise InputError(f"{path}: cannot write the HDF5 mask ({exc})") from None


def _thresholds(settings: list[str]) -> DefectThresholds:
    from ares.analysis.defects import DefectThresholds

    attrs = {}
    for item in settings:
        name, sep, value = item.partition("=")
        if not sep:
            raise InputError(f"--set {item!r}: expected NAME=VALUE")
        attrs[name.strip()] = value
    return DefectThresholds.from_attrs(attrs, where="--set")


def _text(res: DefectResult) -> str:
    out = [f"{res.shape[1]} x {res.shape[0]} pixels, {res.counts['total']} defective pixels "
           f"({res.counts['total'] / (res.shape[0] * res.shape[1]) * 1e6:.1f} ppm)"]
    for c in ("hot", "warm", "stuck", "rts", "noisy", "dead", "low_response", "high_response", "unclassified"):
        n = res.counts[c]
        part = n is not None and res.detection.get(c, "").startswith("incomplete")  # a lower bound
        out.append(f"  {c:<14} {'n/a' if n is None else ('>= ' if part else '') + str(n):>8}")
    out.append(f"  {'bad columns':<14} {res.counts['bad_columns']:>8}  " +
               " ".join(str(c["x"]) for c in res.bad_columns[:20]))
    out.append(f"  {'bad rows':<14} {res.counts['bad_rows']:>8}  " + " ".join(str(r["y"]) for r in res.bad_rows[:20]))
    hist = ", ".join(f"{k}px: {v}" for k, v in sorted(res.clusters["size_histogram"].items()))
    out.append(f"  {'clusters':<14} {res.counts['clusters']:>8}  (group sizes {hist or 'none'})")
    if res.rts_available:
        out.append(f"  {res.rts_note}")
    out.extend(f"  {c}: {why}" for c, why in res.detection.items() if why.startswith("incomplete"))
    out.extend(f"  {c}: not available: {why}" for c, why in res.unavailable.items())
    out.extend(f"  note: {n}" for n in res.notes)
    for lim in res.limits:
        out.append(f"  limit {lim['name']}: {lim['count']} (max {lim['max']})  {'PASS' if lim['passed'] else 'FAIL'}")
    return "\n".join(out)


def _jsonable(x):
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_jsonable(v) for v in x]
    return x


def _per_level(values, n: int, option: str):
    if values is not None and len(values) not in (1, n):
        raise InputError(f"{option}: {len(values)} values for {n} levels")
    return [None] * n if values is None else (list(values) if len(values) == n else list(values) * n)


def classify_files(dark_levels, flat_levels, *, gain=None, exposure=None, flat_exposure=None, thresholds=None,
                   regions=None) -> tuple[dict[str, DefectResult], tuple[int, int]]:
    """Both passes on recorded files, streamed: per-pixel statistics of every level, then the
    candidates' time series from the first dark level for the RTS test. Returns the
    results (per region, or ``{"all": ...}``) and the frame shape."""
    from ares.analysis.defects import classify_defects, classify_regions

    dexp = _per_level(exposure, len(dark_levels), "--exposure")
    fexp = _per_level(flat_exposure if flat_exposure is not None else (exposure if exposure and len(exposure) == 1
                                                                       else None),
                      len(flat_levels), "--flat-exposure")
    darks = [level_stats(p, e, "dark") for p, e in zip(dark_levels, dexp)]
    flats = [level_stats(p, e, "flat") for p, e in zip(flat_levels, fexp)]
    for s in darks[1:] + flats:
        if s.shape != darks[0].shape:
            raise InputError(f"dark and flat frames differ in size ({s.shape} vs {darks[0].shape})")

    def classify(series):
        kw = dict(gain_dn_per_e=gain, thresholds=thresholds, rts_series=series)
        if regions:
            return classify_regions(darks, flats, regions, **kw)
        return {"all": classify_defects(darks, flats, **kw)}

    first = classify(None)
    rows, cols = _global_candidates(first, regions)
    if rows.size == 0:
        return first, darks[0].shape
    return classify(candidate_series(dark_levels[0], rows, cols)), darks[0].shape


def run(args) -> int:
    import numpy as np

    from ares.safefile import output_file, writing

    for opt, path in (("--mask-png", args.mask_png), ("--mask-h5", args.mask_h5)):  # before the work
        if path:
            output_file(path, opt)
    th = _thresholds(args.settings)
    regions = BAYER_PHASES if args.bayer else None
    k = args.gain.dn_per_e(args.adc_lsb_uv) if args.gain is not None else None
    results, shape = classify_files(args.dark, args.flat or [], gain=k, exposure=args.exposure,
                                    flat_exposure=args.flat_exposure, thresholds=th, regions=regions)
    mask = np.zeros(shape, np.uint16)
    for name, res in results.items():
        rs, cs = regions[name] if regions else (slice(None), slice(None))
        mask[rs, cs] = res.mask
    if args.mask_png:
        with writing(args.mask_png):
            write_mask_png(args.mask_png, mask)
    if args.mask_h5:
        with writing(args.mask_h5):
            write_mask_h5(args.mask_h5, mask, results)
    if args.json:
        doc = {name: r.to_dict() for name, r in results.items()} if regions else results["all"].to_dict()
        print(json.dumps(_jsonable(doc), indent=1))
    else:
        for name, res in results.items():
            if regions:
                print(f"channel {name} (row phase {name[0]}, column phase {name[1]}):")
            print(_text(res))
    failed = sorted({f"{lim['name']}" + (f" ({name})" if regions else "")
                     for name, res in results.items() for lim in res.limits if not lim["passed"]})
    if failed:
        raise LimitsFailed(f"defect limits failed: {', '.join(failed)}")
    return 0
