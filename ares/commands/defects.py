"""``ares defects``: defective pixels, lines and clusters of recorded dark (and flat) stacks.

Each ``--dark FILES...`` (or ``--flat``) occurrence is one level: its files are read in
order and concatenated into one (F, R, C) stack. A file is a ``.npy`` (2-D frame or 3-D
stack), a ``.npz`` (array ``frames``, else its first array) or a grayscale image
(PNG/TIFF, one frame). Prints counts per class, bad lines, clusters and the pass/fail of
any ``max_*`` limits (``--set max_hot=10``; a failed limit exits 4); ``--json`` prints
the full result; ``--mask-png``/``--mask-h5`` write the per-pixel class bitmask (bits in
the JSON ``mask_bits``); ``--bayer`` classifies each colour channel (Bayer phase)
against its own statistics.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ares.analysis.defects import BITS, DefectResult, DefectThresholds, classify_stack
from ares.errors import InputError, LimitsFailed

#: the four Bayer phases as (row slice, column slice), named by (row % 2, column % 2)
BAYER_PHASES = {f"{r}{c}": (slice(r, None, 2), slice(c, None, 2)) for r in (0, 1) for c in (0, 1)}

NAME = "defects"
HELP = "defective pixel identification and counting on recorded dark/flat stacks"


def add_arguments(p) -> None:
    p.add_argument("--dark", nargs="+", action="append", required=True, metavar="FILE",
                   help="dark frames/stacks of one level (repeat the option for more levels)")
    p.add_argument("--flat", nargs="+", action="append", default=None, metavar="FILE",
                   help="illuminated frames/stacks of one level (repeatable)")
    p.add_argument("--gain", type=float, default=None, metavar="K", help="system gain in DN/e-")
    p.add_argument("--exposure", type=float, nargs="+", default=None, metavar="S",
                   help="exposure time(s) in s: one for all levels, or one per dark level")
    p.add_argument("--flat-exposure", type=float, nargs="+", default=None, metavar="S",
                   help="exposure time(s) of the flat levels (default: --exposure)")
    p.add_argument("--set", dest="settings", action="append", default=[], metavar="NAME=VALUE",
                   help="override a threshold or limit, e.g. --set hot_e_per_s=5 --set max_hot=100")
    p.add_argument("--bayer", action="store_true",
                   help="classify each Bayer phase (colour channel) separately against its own statistics")
    p.add_argument("--json", action="store_true", help="print the full result as JSON")
    p.add_argument("--mask-png", default=None, metavar="FILE", help="write the class bitmask as a 16-bit PNG")
    p.add_argument("--mask-h5", default=None, metavar="FILE", help="write the class bitmask to an HDF5 file")


def load_frames(path: str | Path) -> np.ndarray:
    """One file as an (F, R, C) unsigned integer array; errors name the file."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    suffix = path.suffix.lower()
    if suffix in (".npy", ".npz"):
        try:
            data = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: not a readable numpy file ({exc})") from None
        if suffix == ".npz":
            with data:
                if not data.files:
                    raise InputError(f"{path}: the archive holds no arrays")
                arr = data["frames"] if "frames" in data.files else data[data.files[0]]
        else:
            arr = data
    else:
        from ares.hardware.imagefile import read_image

        arr = read_image(path)
    arr = np.asarray(arr)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3:
        raise InputError(f"{path}: expected a 2-D frame or a 3-D stack, got shape {arr.shape}")
    if arr.dtype.kind not in "ui" or (arr.dtype.kind == "i" and arr.size and arr.min() < 0):
        raise InputError(f"{path}: pixel type {arr.dtype} is not raw unsigned integer data")
    return arr


def load_level(paths: list[str]) -> np.ndarray:
    stacks = [load_frames(p) for p in paths]
    shapes = {s.shape[1:] for s in stacks}
    if len(shapes) != 1:
        raise InputError(f"{paths[0]}: frames of different sizes in one level ({sorted(shapes)})")
    return stacks[0] if len(stacks) == 1 else np.concatenate(stacks, axis=0)


def write_mask_png(path: str | Path, mask: np.ndarray) -> None:
    """The uint16 class bitmask as a lossless 16-bit grayscale PNG (values are the bits)."""
    from PIL import Image

    try:
        Image.fromarray(np.ascontiguousarray(mask, dtype=np.uint16)).save(Path(path), format="PNG")
    except OSError as exc:
        raise InputError(f"{path}: cannot write the mask PNG ({exc})") from None


def write_mask_h5(path: str | Path, mask: np.ndarray, results: dict[str, DefectResult]) -> None:
    """Dataset ``defects/mask`` (uint16 bits, attributes ``bit_<class>``) and the counts as JSON."""
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
    for c in ("hot", "warm", "stuck", "rts", "noisy", "dead", "low_response", "high_response"):
        n = res.counts[c]
        out.append(f"  {c:<14} {'n/a' if n is None else n:>8}")
    out.append(f"  {'bad columns':<14} {res.counts['bad_columns']:>8}  " +
               " ".join(str(c["x"]) for c in res.bad_columns[:20]))
    out.append(f"  {'bad rows':<14} {res.counts['bad_rows']:>8}  " + " ".join(str(r["y"]) for r in res.bad_rows[:20]))
    hist = ", ".join(f"{k}px: {v}" for k, v in sorted(res.clusters["size_histogram"].items()))
    out.append(f"  {'clusters':<14} {res.counts['clusters']:>8}  (group sizes {hist or 'none'})")
    out.append(f"  {res.rts_note}")
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


def run(args) -> int:
    th = _thresholds(args.settings)
    darks = [load_level(paths) for paths in args.dark]
    flats = [load_level(paths) for paths in (args.flat or [])]
    shape = darks[0].shape[1:]
    for s in darks + flats:
        if s.shape[1:] != shape:
            raise InputError(f"dark and flat frames differ in size ({s.shape[1:]} vs {shape})")
    for s in darks:
        if s.shape[0] < 2:
            raise InputError("each dark level needs at least 2 frames for a temporal variance")
    exp = args.exposure
    if exp is not None and len(exp) not in (1, len(darks)):
        raise InputError(f"--exposure: {len(exp)} values for {len(darks)} dark levels")
    exposure = None if exp is None else (exp[0] if len(exp) == 1 else exp)
    fexp = args.flat_exposure
    if fexp is not None and len(fexp) not in (1, len(flats)):
        raise InputError(f"--flat-exposure: {len(fexp)} values for {len(flats)} flat levels")
    flat_exposure = None if fexp is None else (fexp[0] if len(fexp) == 1 else fexp)
    if args.gain is not None and not args.gain > 0:
        raise InputError("--gain must be a positive number of DN per electron")
    regions = BAYER_PHASES if args.bayer else None
    out = classify_stack(darks, flats or None, gain_dn_per_e=args.gain, exposure_s=exposure,
                         flat_exposure_s=flat_exposure, thresholds=th, regions=regions)
    results = out if isinstance(out, dict) else {"all": out}
    mask = np.zeros(shape, np.uint16)
    for name, res in results.items():
        rs, cs = regions[name] if regions else (slice(None), slice(None))
        mask[rs, cs] = res.mask
    if args.mask_png:
        write_mask_png(args.mask_png, mask)
    if args.mask_h5:
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
