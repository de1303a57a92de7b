"""The defect mask a scan analyses its later stages with (issue 9: defects out of the noise figures).

Two stuck pixels made the main job's pixel FPN 86.6 DN^2 instead of 1.86: every headline
noise figure (DSNU, the sensor-noise floor, the PRNU of the total-noise model) came from
them. The runner therefore builds a mask before the later stages stream -- from the first
dark stage's mean and variance maps (``ares.analysis.defects``: stuck, hot, warm, noisy,
RTS candidates; the classes that are available at that stage's frame count), or from a
file the scan names (``<defects mask="...">``) -- and accumulates the full view of every
later stage over the good pixels as well (``MaskedStackAccumulator``, unbiased for any
mask). Both the masked and the unmasked figures are kept; the defect *counts* always come
from the unmasked maps, and row/column defects are never masked (they are part of the
row/column FPN a user must see).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ares.errors import InputError

MAX_MASK_BYTES = 512 * 1024 * 1024


@dataclass(frozen=True)
class DefectMask:
    mask: np.ndarray  # bool (rows, cols), True = excluded from the masked figures
    source: str  # "dark stage NAME" or the file
    classes: dict  # class -> pixels masked (from a classification)
    # the dark stage's RTS candidates (rows, cols): their time series is kept from its frames
    # for the defects analysis (RTS by levels: a trap is not a noisy or a hot pixel)
    rts_candidates: tuple | None = None
    # why the mask is not final yet (ares.scan.mask_complete: a flat will complete it), or None
    provisional: str | None = None
    # temporal classes its stack had too few frames (or codes) to test: class -> the classifier's sentence
    unseen: dict = field(default_factory=dict)

    @property
    def count(self) -> int:
        return int(self.mask.sum())

    def summary(self) -> dict:
        out = {"masked_pixels": self.count, "mask_source": self.source, "mask_classes": dict(self.classes)}
        if self.provisional:
            out["provisional"] = self.provisional
        if self.unseen:
            out["mask_incomplete"] = dict(self.unseen)
        return out


def mask_from_dark(stackset, stage_name: str, exposure_s: float | None, thresholds) -> DefectMask:
    """Pixel defects of a finished dark stage's full view (z-mode: no gain is known yet)."""
    from ares.analysis.defects import PixelStats, classify_defects
    from ares.analysis.defects.result import PIXEL_BITS, PIXEL_CLASSES, primary_class

    acc = stackset.acc["full"]
    st = PixelStats.from_accumulator(acc, exposure_s)  # the float64 maps themselves: no copies
    res = classify_defects([st], None, thresholds=thresholds)
    mask = (res.mask & PIXEL_BITS) != 0
    prim = primary_class(res.mask)
    classes: dict = {}
    for i, c in enumerate(PIXEL_CLASSES):
        k = int(np.count_nonzero(prim == i))
        if k:
            classes[_mask_label(c)] = classes.get(_mask_label(c), 0) + k
    unseen = {c: res.unavailable[c] for c in UNSEEN_CLASSES if c in res.unavailable}
    return DefectMask(mask, f"dark stage {stage_name}", classes, res.rts_candidates, unseen=unseen)


#: the classes whose pixels, left in, read as pixel FPN of a short stack: a noisy pixel (its
#: own scatter in the stack mean), and the telegraph (RTS) traps the noisy test is what masks
#: (the mask has no time series for the RTS test) -- a trap switching less often than the
#: frames holds a level over the stack, a fixed pattern there
UNSEEN_CLASSES = ("noisy",)


def bound_incomplete(components: dict, mask: DefectMask) -> dict:
    """The masked components (their JSON form) of a stage whose mask could not test
    ``mask.unseen`` (too few frames in the stack it came from): the pixel FPN Ps becomes an
    upper limit, the estimate + 3 SE (``stats.physical.NSIGMA``: one limit rule), with the
    sentence why and the estimate in its note. The
    pixels left in raise Ps by an amount no stack this short measures (a slow trap's level over
    the stack is a fixed offset there; a noisy pixel widens the estimate's scatter): bench,
    photon_transfer at 16 frames, 3 of 24 "ok" Ps beyond 3 SE of the defect-free truth, and
    every bound holding it (benchmarks/truth_z.md)."""
    ps = components.get("Ps")
    if not mask.unseen or not isinstance(ps, dict) or ps.get("verdict") != "ok" or ps.get("se") is None:
        return components
    from ares.analysis.stats.estimate import Estimate
    from ares.analysis.stats.physical import NSIGMA

    why = "; ".join(f"{c}: {w}" for c, w in mask.unseen.items())
    out = dict(components)
    out["Ps"] = Estimate.limit(
        ps["value"] + NSIGMA * ps["se"], "upper", ps.get("unit", "DN^2"),
        f"defect mask incomplete ({why}): noisy and slow telegraph (RTS) pixels below detection may "
        f"remain and raise the pixel FPN; {ps['value']:.4g} +- {ps['se']:.2g} over the good pixels, + {NSIGMA:g} SE").to_dict()
    return out


def _mask_label(cls: str) -> str:
    """The mask's name for a class found without K: hot/warm there only say the averaged
    dark is far above its neighbours at one exposure -- a hot pixel or a trap held high
    for the whole stack, not told apart (the defects analysis, with K and the exposures,
    is where a pixel is called hot)."""
    return "dark_outlier" if cls in ("hot", "warm") else cls


def flat_can_classify(flat, dark, thresholds) -> bool:
    """Whether a finished flat stage (with its matched dark, both ``StackSet``) shows the
    flat classes: a pixel responding ``low_response_fraction`` (or ``high_response_fraction``)
    of its neighbours is found with 99 % probability (the classifier's significance test,
    ``ares.analysis.defects.classify``), and the level is not clipped. Cheap: sampled medians."""
    from ares.analysis.defects.limits import Z99
    from ares.analysis.defects.robust import sampled_median

    fa, da = flat.acc["full"], dark.acc["full"]
    n = fa.n_frames * fa.shape[0] * fa.shape[1]
    if not n or flat.at_max["full"] / n >= 0.002:
        return False
    resp = sampled_median(fa.mean_map() - da.mean_map())
    noise = np.sqrt(max(sampled_median(fa.temporal_var_map()), 0.0) / fa.n_frames
                    + max(sampled_median(da.temporal_var_map()), 0.0) / max(da.n_frames, 1))
    step = min(1.0 - thresholds.low_response_fraction, thresholds.high_response_fraction - 1.0)
    return bool(resp > 0 and step * resp >= (thresholds.warm_z + Z99) * noise)


def mask_with_flat(base: DefectMask, dark, dark_exposure_s, flat, flat_name: str, thresholds) -> DefectMask:
    """``base`` (the first dark stage's classes) joined by the classes a flat stage shows
    (dead, low/high response, stuck in the light) against its matched dark: the one mask
    every stage's masked figures use (issue 34: PRNU was 27 SE high while the dead pixels,
    visible only in a flat, stayed in it)."""
    from ares.analysis.defects import PixelStats, classify_defects
    from ares.analysis.defects.result import PIXEL_BITS, PIXEL_CLASSES, primary_class

    res = classify_defects([PixelStats.from_accumulator(dark.acc["full"], dark_exposure_s)],
                           [PixelStats.from_accumulator(flat.acc["full"], None)], thresholds=thresholds)
    found = (res.mask & PIXEL_BITS) != 0
    added = found & ~base.mask
    prim = primary_class(res.mask)
    classes = dict(base.classes)
    for i, c in enumerate(PIXEL_CLASSES):
        k = int(np.count_nonzero(added & (prim == i)))
        if k:
            classes[_mask_label(c)] = classes.get(_mask_label(c), 0) + k
    return DefectMask(base.mask | found, f"{base.source} and flat stage {flat_name}", classes, base.rts_candidates,
                      unseen=dict(base.unseen))


def load_mask_file(path: Path, shape: tuple[int, int]) -> DefectMask:
    """A declared mask: ``.npy`` (bool or integer, non-zero = defect) or a PNG/TIFF image
    (non-zero = defect), the sensor's full array shape."""
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise InputError(f"{path}: defect mask file cannot be read ({exc.strerror or exc})") from None
    if not path.is_file():
        raise InputError(f"{path}: defect mask is not a regular file")
    if size > MAX_MASK_BYTES:
        raise InputError(f"{path}: defect mask file is {size} bytes, more than any sensor mask needs")
    try:
        if path.suffix.lower() == ".npy":
            a = np.load(path, allow_pickle=False)
        else:
            from PIL import Image

            with Image.open(path) as im:
                a = np.asarray(im)
    except Exception as exc:  # noqa: BLE001 -- any decoder error is one sentence about the file
        raise InputError(f"{path}: not a readable defect mask ({type(exc).__name__})") from None
    if a.ndim != 2 or tuple(a.shape) != tuple(shape):
        raise InputError(f"{path}: defect mask of shape {tuple(a.shape)} does not match the sensor's "
                         f"{shape[0]} x {shape[1]} array")
    m = np.asarray(a) != 0
    return DefectMask(m, str(path), {"declared": int(m.sum())})


def scan_thresholds(scan):
    """The scan's ``<defects>`` thresholds (validated at load)."""
    from ares.analysis.defects import DefectThresholds

    return DefectThresholds.from_attrs(dict(scan.defects), where=f"{scan.source}: <defects>")


def load_declared_mask(scan, shape) -> DefectMask | None:
    """The mask file a scan names (``<defects mask=...>``, relative to the scan), or None."""
    if not scan.defect_mask:
        return None
    base = Path(scan.source).parent if scan.source else Path.cwd()
    return load_mask_file(base / scan.defect_mask, tuple(shape))
