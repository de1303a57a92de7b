"""Regions of analysis and channels, as zero-copy numpy views of a frame.

A ``Selection`` is a pair of basic slices (rows, columns) with a name: slicing a frame
with it returns a *view* (never a copy). Built from:

* ``Region(x, y, w, h, enabled=True, name=...)`` -- a rectangle (x = first column);
* ``bayer_channels(cfa, region)`` -- the four Bayer phases ``data[r0::2, c0::2]``;
* ``adc_channels(period, region)`` -- columns interleaved over ``period`` ADCs
  (column parity for 2);
* ``ob_columns(start, stop)`` -- optically black columns.

Phases and interleaves are anchored to the *sensor* (absolute row/column parity), so a
region starting on an odd column still sees the right Bayer colour / ADC.
``SelectionSet`` feeds one ``StackAccumulator`` per enabled selection.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ares.errors import InputError

from ares.analysis.noise.accumulate import StackAccumulator

__all__ = [
    "Region",
    "Selection",
    "SelectionSet",
    "bayer_channels",
    "adc_channels",
    "ob_columns",
    "full_frame",
    "parse_roi",
    "region_selection",
]


@dataclass(frozen=True)
class Region:
    """A rectangle of analysis: x (first column), y (first row), width, height."""

    x: int
    y: int
    w: int
    h: int
    enabled: bool = True
    name: str = ""

    def label(self) -> str:
        return self.name or f"roi {self.x},{self.y},{self.w},{self.h}"

    def check(self, frame_shape) -> None:
        R, C = frame_shape
        if self.w < 1 or self.h < 1:
            raise InputError(f"region '{self.label()}' has width {self.w} and height {self.h}; both must be >= 1")
        if self.x < 0 or self.y < 0 or self.x + self.w > C or self.y + self.h > R:
            raise InputError(
                f"region '{self.label()}' (x={self.x}, y={self.y}, w={self.w}, h={self.h}) "
                f"lies outside the {C}x{R} frame (width x height)"
            )


def parse_roi(text: str, name: str = "") -> Region:
    """'X,Y,W,H' -> Region (InputError on a malformed string)."""
    try:
        x, y, w, h = (int(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"region '{text}' must be four integers X,Y,W,H") from None
    return Region(x, y, w, h, name=name or f"roi {text}")


@dataclass(frozen=True)
class Selection:
    """A named (rows, cols) pair of basic slices into a frame; ``sel(frame)`` is a view."""

    name: str
    rows: slice
    cols: slice
    enabled: bool = True

    def __call__(self, frame: np.ndarray) -> np.ndarray:
        if frame.ndim == 3:  # a stack: same selection on every frame, still a view
            return frame[:, self.rows, self.cols]
        return frame[self.rows, self.cols]

    def shape(self, frame_shape) -> tuple[int, int]:
        R, C = frame_shape
        return (len(range(*self.rows.indices(R))), len(range(*self.cols.indices(C))))

    def check(self, frame_shape) -> None:
        r, c = self.shape(frame_shape)
        if r < 1 or c < 1:
            raise InputError(f"selection '{self.name}' holds no pixels of the {frame_shape[1]}x{frame_shape[0]} frame")


def full_frame(frame_shape, name: str = "full frame") -> Selection:
    return Selection(name, slice(0, frame_shape[0]), slice(0, frame_shape[1]))


def _region_sel(region: Region | None, frame_shape, r_phase=0, c_phase=0, r_step=1, c_step=1):
    if region is None:
        y, x, h, w = 0, 0, frame_shape[0], frame_shape[1]
    else:
        region.check(frame_shape)
        y, x, h, w = region.y, region.x, region.h, region.w
    r0 = y + ((r_phase - y) % r_step)
    c0 = x + ((c_phase - x) % c_step)
    return slice(r0, y + h, r_step), slice(c0, x + w, c_step)


def region_selection(region: Region, frame_shape) -> Selection:
    rs, cs = _region_sel(region, frame_shape)
    return Selection(region.label(), rs, cs, region.enabled)


_PHASES = ((0, 0), (0, 1), (1, 0), (1, 1))


def bayer_channels(frame_shape, cfa: str | None = None, region: Region | None = None) -> list[Selection]:
    """The four Bayer phases; named by the CFA letters (Gr/Gb for the greens) if given."""
    if cfa is not None:
        cfa = cfa.upper()
        if sorted(cfa) != sorted("RGGB"):
            raise InputError(f"CFA pattern '{cfa}' is not one of RGGB, GRBG, GBRG, BGGR")
    out = []
    for i, (r0, c0) in enumerate(_PHASES):
        if cfa is None:
            name = f"phase {r0}{c0}"
        else:
            letter = cfa[i]
            name = letter if letter != "G" else ("Gr" if "R" in cfa[2 * r0 : 2 * r0 + 2] else "Gb")
        if region is not None:
            name = f"{region.label()} {name}"
        rs, cs = _region_sel(region, frame_shape, r0, c0, 2, 2)
        out.append(Selection(name, rs, cs, region.enabled if region else True))
    for s in out:
        s.check(frame_shape)
    return out


def adc_channels(frame_shape, period: int = 2, region: Region | None = None) -> list[Selection]:
    """Columns interleaved over ``period`` ADC channels (channel k: columns c % period == k)."""
    if period < 1:
        raise InputError(f"ADC interleave period must be >= 1, got {period}")
    out = []
    for k in range(period):
        rs, cs = _region_sel(region, frame_shape, 0, k, 1, period)
        name = f"ADC {k}/{period}" + (f" {region.label()}" if region else "")
        out.append(Selection(name, rs, cs, region.enabled if region else True))
    for s in out:
        s.check(frame_shape)
    return out


def ob_columns(frame_shape, start: int, stop: int, name: str = "optically black") -> Selection:
    """Optically black columns ``start:stop`` over all rows."""
    R, C = frame_shape
    if not 0 <= start < stop <= C:
        raise InputError(f"optically black columns {start}:{stop} lie outside the {C}-column frame")
    return Selection(name, slice(0, R), slice(start, stop))


class SelectionSet:
    """One ``StackAccumulator`` per enabled selection; ``add(frame)`` feeds them all."""

    def __init__(self, frame_shape, selections, **acc_kw):
        self.frame_shape = tuple(frame_shape)
        sels = []
        for s in selections:
            if isinstance(s, Region):
                s = region_selection(s, self.frame_shape)
            s.check(self.frame_shape)
            if s.enabled:
                sels.append(s)
        names = [s.name for s in sels]
        if len(set(names)) != len(names):
            raise InputError(f"selection names must be unique, got {names}")
        self.selections = sels
        self.accumulators = {s.name: StackAccumulator(s.shape(self.frame_shape), **acc_kw) for s in sels}

    def add(self, frame) -> None:
        frame = np.asarray(frame)
        if frame.shape != self.frame_shape:
            n = next(iter(self.accumulators.values())).n_frames if self.accumulators else 0
            raise InputError(f"frame {n} has shape {frame.shape}, but this stack's frames are {self.frame_shape}")
        for s in self.selections:
            self.accumulators[s.name].add(s(frame))

    def add_batch(self, frames) -> None:
        frames = np.asarray(frames)
        if frames.ndim != 3 or frames.shape[1:] != self.frame_shape:
            raise InputError(f"a batch must have shape (frames, {self.frame_shape[0]}, {self.frame_shape[1]}), got {frames.shape}")
        for s in self.selections:
            self.accumulators[s.name].add_batch(s(frames))

    def __getitem__(self, name: str) -> StackAccumulator:
        return self.accumulators[name]

    def items(self):
        return self.accumulators.items()
