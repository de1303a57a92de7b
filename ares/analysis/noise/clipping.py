"""Clipped pixels of a frame stack: pixels that reach the top of the code range (the data
type's maximum, a declared ADC full scale, or the stack's own maximum when it is an ADC's
2^b - 1 held by pixels in every frame) or the bottom (0, integer data) in any frame. Their
values are not the sensor's signal, so no variance or mean made from them means what it
says: a stack entirely at 65535 has every variance 0; half the pixels clipped halves the
pixel variance and puts the step between the two halves into the column variance.

``ClipScan`` streams the frames (per-pixel minimum and maximum, one pass) and says which
pixels to exclude and why (``combine``: one mask for a flat and its dark); ``clipped_na`` and ``flag_clipped`` turn that into verdicts: a
stack with too few unclipped pixels gets every figure "not available" with the reason; a
partly clipped one is analysed on the unclipped pixels (masked decomposition,
``ares.analysis.noise.masked``) and every figure carries the count in its note.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ares.analysis.stats.estimate import Estimate


def adc_full_scale(bits: int) -> int:
    return int(2 ** int(bits) - 1)


class ClipScan:
    """Per-pixel extremes of a stack (``add(frame)``), and the clipped-pixel mask they give.

    ``top``: the full-scale code when known (the ADC's declared bits); else the data type's
    maximum for integer frames. ``zero``: whether 0 counts as clipping (integer frames)."""

    def __init__(self, top: float | None = None, top_source: str = ""):
        self.top, self.top_source = top, top_source
        self.lo = self.hi = None
        self.dtype = None
        self.n_frames = 0

    def add(self, frame) -> None:
        f = np.asarray(frame)
        if self.hi is None:
            self.dtype = f.dtype
            self.lo, self.hi = f.copy(), f.copy()
        else:
            np.minimum(self.lo, f, out=self.lo)
            np.maximum(self.hi, f, out=self.hi)
        self.n_frames += 1

    def _top(self) -> tuple[float | None, str]:
        if self.top is not None:
            return self.top, self.top_source or "the declared full scale"
        if self.dtype is None or not np.issubdtype(self.dtype, np.integer):
            return None, ""
        dmax = int(np.iinfo(self.dtype).max)
        m = int(self.hi.max())
        if m >= dmax:
            return dmax, f"{self.dtype}'s maximum"
        b = m.bit_length()
        if m >= 255 and m == adc_full_scale(b) and bool(np.any(self.lo == m)):
            return m, f"the stack's maximum, 2^{b} - 1, held by pixels in every frame: an ADC's full scale"
        return None, ""

    def summary(self) -> dict:
        """``{"mask", "pixels", "at_top", "at_zero", "total", "top_dn", "top_source"}``: the
        clipped pixels (True = excluded) and their counts."""
        if self.hi is None:
            raise ValueError("no frames scanned")
        top, src = self._top()
        at_top = self.hi >= top if top is not None else np.zeros(self.hi.shape, bool)
        integer = np.issubdtype(self.dtype, np.integer)
        at_zero = self.lo <= 0 if integer else np.zeros(self.hi.shape, bool)
        return _summary(at_top, at_zero, top, src)


def _summary(at_top, at_zero, top, src) -> dict:
    mask = at_top | at_zero
    return {"mask": mask, "top_mask": at_top, "zero_mask": at_zero, "pixels": int(mask.sum()), "at_top": int(at_top.sum()),
            "at_zero": int(at_zero.sum()), "total": int(mask.size), "top_dn": top, "top_source": src}


def combine(a: dict, b: dict) -> dict:
    """One clipping summary for two stacks of one frame shape (flat and dark: one mask for both)."""
    top = a["top_dn"] if a["at_top"] or not b["at_top"] else b["top_dn"]
    src = a["top_source"] if top == a["top_dn"] else b["top_source"]
    return _summary(a["top_mask"] | b["top_mask"], a["zero_mask"] | b["zero_mask"], top, src)


def describe(s: dict) -> str:
    """One sentence: how many pixels are clipped, where."""
    parts = []
    if s["at_top"]:
        parts.append(f"{s['at_top']} at the top code {s['top_dn']:g} ({s['top_source']})")
    if s["at_zero"]:
        parts.append(f"{s['at_zero']} at 0")
    return (f"{s['pixels']} of {s['total']} pixels ({100.0 * s['pixels'] / s['total']:.3g} %) are clipped in at "
            f"least one frame: " + ", ".join(parts))


def too_clipped(s: dict) -> str | None:
    """The reason no figure can be made (fewer than 2 rows and 2 columns of unclipped pixels
    with 2 good pixels each), or None."""
    good = ~s["mask"]
    rows = int(np.sum(good.sum(axis=1) >= 2))
    cols = int(np.sum(good.sum(axis=0) >= 2))
    if rows >= 2 and cols >= 2:
        return None
    where = " and ".join(([f"{s['top_dn']:g} ({s['top_source']})"] if s["at_top"] else []) + (["0"] if s["at_zero"] else []))
    if not good.any():
        return f"every pixel is clipped (at {where}) in at least one frame: the values are not the sensor's signal"
    return (f"{s['pixels']} of {s['total']} pixels are clipped (at {where}): fewer than 2 rows and 2 columns of "
            "unclipped pixels are left to decompose")


def clipped_na(estimates: dict[str, Estimate], reason: str) -> dict[str, Estimate]:
    """Every figure not available, with the clipping reason."""
    return {k: Estimate.na(reason, e.unit) for k, e in estimates.items()}


def flag_clipped(estimates: dict[str, Estimate], s: dict) -> dict[str, Estimate]:
    """Every available figure with the clipped pixels' count in its note (they were excluded)."""
    tag = f"{s['pixels']} clipped pixels ({100.0 * s['pixels'] / s['total']:.3g} %) excluded"
    out = {}
    for k, e in estimates.items():
        out[k] = dataclasses.replace(e, note=f"{e.note}; {tag}" if e.note else tag) if e.available else e
    return out
