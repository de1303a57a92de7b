"""A stage's frames turned into its result (the runner's half of every analysis).

A stage result is a JSON-able dict::

    {"index", "name", "group", "scene", "frames", "dark_frames", "settings", "coords",
     "views": {view: {"level": {...}, "components": {name: Estimate dict},
                      "dark_level": {...}, "dark_components": {...}}}}

Views are ``full``, each scan region, each CFA phase (``cfa_R`` ...) and each ADC channel
(``adc0``, ``adc1`` ... for interleaved ADCs). ``level`` holds mean (DN), temporal
variance (DN^2, frame-global offset removed, as ``ares.analysis.ptc.levels.stack_stats``),
spatial variance and clip fractions, plus ``frame_means`` (DN per frame). ``components``:
for a dark stage (or a flat one without a dark) ``decompose_dark`` of its stack; for a
flat stage with a matched dark the 13 components -- ``decompose_dark`` of the dark stack
(o, Cs, Ct, Rs, Rt, Ps, Pt, frame_global) plus ``decompose_flat(flat, dark)`` (G, Cg, Rg,
Pg, q, delta, signal) -- and ``flat_anova``, the ANOVA of the flat stack itself.
"""

from __future__ import annotations

import math
import numpy as np
from ares.analysis import StackAccumulator, anova_table, decompose_dark
from ares.analysis.noise.masked import MaskedStackAccumulator
from ares.errors import InputError


def views(scan) -> dict[str, tuple[slice, slice]]:
    sensor = scan.system.sensor
    v = {"full": FULL}
    for r in scan.regions:
        v[r.name] = r.slices()
    if sensor.cfa != "mono":
        for k, letter in enumerate(sensor.cfa):
            name = {"G": "Gr" if k < 2 else "Gb"}.get(letter, letter)
            v[f"cfa_{name}"] = (slice(k // 2, None, 2), slice(k % 2, None, 2))
    n = sensor.adc_channels
    if n > 1:
        for k in range(n):
            if sensor.adc_interleave == "row":
                v[f"adc{k}"] = (slice(k, None, n), slice(None))
            else:  # column (ping-pong) and pixel interleave: alternate columns
                v[f"adc{k}"] = (slice(None), slice(k, None, n))
    return v


def batch_for(shape) -> int:
    """Frames an accumulator buffers before folding: 16 (fastest) up to 1080p, fewer for
    larger frames so the store stays under BATCH_BYTES (4096x3072: 2). The sums are exact
    integers, so the batch size never changes a result."""
    return max(2, min(16, BATCH_BYTES // (2 * shape[0] * shape[1])))


RAMP_GROUPS = 16  # sub-histograms an ADC ramp stage keeps (frame i in i mod 16): 15 dof for its SEs


class StackSet:
    """One accumulator per view, plus clip counters."""

    def __init__(self, shape, views_: dict, max_code: int, histograms: bool = False, mask=None, groups: int = 0):
        self.views = views_
        # the full view over the good pixels of a defect mask too (ares.scan.defect_mask)
        self.kept = None  # a KeptFrames (ares.scan.kept): the frames of the stage a mask is built from
        self.series_pixels = None  # (rows, cols) whose time series apply_mask keeps (RTS candidates)
        self.series = None  # their SeriesCollector, once the kept frames were read
        self.max_code = max_code
        self.hist = {k: np.zeros(max_code + 1, np.int64) for k in views_
                     if k == "full" or k.startswith(("adc", "cfa_"))} if histograms else {}
        # the ADC ramp's histograms again as ``groups`` sub-histograms, frame i in group i mod
        # groups: the INL/DNL SEs come from their scatter (ares.analysis.ptc.adc.from_histogram)
        self.hist_groups = {k: np.zeros((groups, max_code + 1), np.int64) for k in self.hist} if groups >= 2 else {}
        self._added = 0  # frames added (the group of the next one)
        dummy = np.empty(shape, dtype=np.uint8)
        self.acc = {k: StackAccumulator(dummy[s].shape, batch=batch_for(dummy[s].shape)) for k, s in views_.items()}
        for acc in self.acc.values():  # clip counts in the accumulators' pass over each pixel
            acc.count_clips(max_code)
        # its per-pixel sums come from the full view's (integer frames): not kept twice
        self.masked = MaskedStackAccumulator(shape, mask, pixels=self.acc["full"]) if mask is not None else None
        self.frame_meta: list[tuple[int, float, float]] = []  # (counter, timestamp, temperature C or nan) per frame

    def note_frame(self, frame) -> None:
        """A frame's metadata: the device's frame counter (ares32 header ``counter``, GenICam
        ``frame_id``; else the frame source's own count), its timestamp, and the device
        temperature when the source reports one (``temperature_c``)."""
        m = frame.meta or {}
        counter = m.get("counter", m.get("frame_id"))
        t, dev = m.get("temperature_c"), m.get("device_timestamp_s")  # (the device's own clock, when it has one)
        self.frame_meta.append((int(frame.index if counter is None else counter), float(frame.timestamp),
                                float("nan") if t is None else float(t), float("nan") if dev is None else float(dev)))

    def add(self, data: np.ndarray) -> None:
        m = self.masked
        if m is not None:  # its line sums from the full view's folds of 8/16-bit frames (one read)
            small = data.dtype.kind in "ui" and data.dtype.itemsize <= 2
            if not small:
                m.unride()
            elif not m.riding:
                m.ride()  # (only while both stacks are empty: it says no otherwise)
        for k, s in self.views.items():
            d = data[s]
            self.acc[k].add(d)  # (its clip counts too)
            if k in self.hist:
                h = np.bincount(d.ravel(), minlength=self.max_code + 1)[: self.max_code + 1]
                self.hist[k] += h
                if k in self.hist_groups:
                    g = self.hist_groups[k]
                    g[self._added % g.shape[0]] += h
        self._added += 1
        if m is not None and not m.riding:
            m.add(data)
        if self.kept is not None:
            self.kept.append(data)

    def compact(self) -> None:
        """The stack is complete: keep the sums, free the accumulators' working buffers."""
        for acc in self.acc.values():
            acc.compact()

    def drop_maps(self) -> None:
        """Forget the float64 maps (mean, variance...) the accumulators cached for the
        stage's analysis: four or five frames' worth each, recomputed from the sums if the
        stack is used again (a reused dark)."""
        for acc in self.acc.values():
            acc._cache.clear()

    def apply_mask(self, mask, close: bool = True) -> bool:
        """Accumulate the kept frames over the good pixels of ``mask`` (after the fact, for
        the stage the mask was built from, or again when a flat completes a provisional
        mask: ``close=False`` keeps the frames for that); False when no frames were kept."""
        if self.kept is None:
            return False
        self.masked = MaskedStackAccumulator(self.acc["full"].shape, mask, pixels=self.acc["full"])
        if self.series_pixels is not None:
            from ares.analysis.defects import SeriesCollector

            self.series = SeriesCollector(*self.series_pixels)
        try:
            for f in self.kept:
                self.masked.add(f)
                if self.series is not None:
                    self.series.add(f)
        finally:
            if close:
                self.kept.close()
                self.kept = None
        return True

    @property
    def at_max(self) -> dict[str, int]:
        """Per view: the values at or above the top code (clipped high) of the frames added."""
        return {k: a.clips()[0] for k, a in self.acc.items()}

    @property
    def at_min(self) -> dict[str, int]:
        """Per view: the values 0 (clipped low) of the frames added."""
        return {k: a.clips()[1] for k, a in self.acc.items()}

    @property
    def n_frames(self) -> int:
        return self.acc["full"].n_frames


def level(ss: StackSet, view: str) -> dict:
    acc = ss.acc[view]
    F = acc.n_frames
    R, C = acc.shape
    n = F * R * C
    mean_map = acc.mean_map()
    out = {"mean_dn": float(acc.mean()), "n_pixels": R * C, "n_frames": F,
           "frame_means": [float(x) for x in acc.frame_means()],
           "frac_at_max": ss.at_max[view] / n, "frac_at_min": ss.at_min[view] / n}
    if F >= 2 and R * C >= 2:
        # pixels x frames without interaction: removing the frame means (the frame-global
        # offset) leaves (RC - 1)(F - 1) degrees of freedom, not RC(F - 1) -- dividing by the
        # latter put a -1/RC bias on every variance (-4 % on a 24-pixel region)
        ss_f = anova_table(acc).ss["F"]
        var = (float(np.nanmean(acc.temporal_var_map())) * (F - 1) * R * C - ss_f) / ((R * C - 1) * (F - 1))
        out["var_dn2"] = var
        out["spatial_var_dn2"] = float(np.var(mean_map, ddof=1)) - var / F if R * C > 1 else math.nan
    else:
        out["var_dn2"] = out["spatial_var_dn2"] = math.nan
    return out


def masked_level(acc: MaskedStackAccumulator, like: dict) -> dict:
    """``level`` over the good pixels of a mask (the frame-global offset removed from the
    pixel temporal variance as in ``level``); the clip fractions are the view's."""
    F, N = acc.n_frames, acc.n_good
    out = {"mean_dn": acc.mean(), "n_pixels": N, "n_frames": F,
           "frame_means": [float(x) for x in acc.frame_means()],
           "frac_at_max": like.get("frac_at_max", 0.0), "frac_at_min": like.get("frac_at_min", 0.0)}
    if F >= 2 and N >= 2:
        fm = np.asarray(acc.frame_means(), float)
        ss_f = N * float(np.sum((fm - fm.mean()) ** 2))
        var = (float(np.nansum(acc.pixel_ss())) - ss_f) / ((N - 1) * (F - 1))  # dof as in level()
        out["var_dn2"] = var
        out["spatial_var_dn2"] = float(np.nanvar(acc.mean_map(), ddof=1)) - var / F
    else:
        out["var_dn2"] = out["spatial_var_dn2"] = math.nan
    return out


def _decompose_flat():
    try:
        from ares.analysis import decompose_flat
    except ImportError:
        try:
            from ares.analysis.noise.flat import decompose_flat
        except ImportError:
            return None
    return decompose_flat


def _components(flat: StackAccumulator, dark: StackAccumulator | None) -> dict:
    """Dark stage: the dark ANOVA. Flat + matched dark: dark components of the dark stack
    plus the gain components (G, Cg, Rg, Pg, q, delta, signal) of the flat -- the 13."""
    if dark is None:
        return {k: e.to_dict() for k, e in decompose_dark(flat).items()}
    out = {k: e.to_dict() for k, e in decompose_dark(dark).items()}
    fn = _decompose_flat()
    if fn is not None:
        try:
            gain = fn(flat, dark)
        except (InputError, ValueError):  # too small for the illumination high-pass
            gain = fn(flat, dark, illumination="none")
        out.update({k: e.to_dict() for k, e in gain.items()})
    return out


def analyze_stage(stage, flat: StackSet, dark: StackSet | None) -> tuple[dict, dict]:
    """(JSON-able result, arrays for HDF5) of one finished stage."""
    res = {"index": stage.index, "name": stage.name, "group": stage.group, "scene": stage.scene,
           "frames": flat.n_frames, "dark_frames": dark.n_frames if dark else 0,
           "dark_source": stage.dark_source, "settings": dict(stage.settings), "coords": list(stage.coords),
           "views": {}}
    for v in flat.views:
        r = {"level": level(flat, v),
             "components": _components(flat.acc[v], dark.acc[v] if dark else None)}
        if dark is not None:
            r["dark_level"] = level(dark, v)
            r["flat_anova"] = {k: e.to_dict() for k, e in decompose_dark(flat.acc[v]).items()}
        res["views"][v] = r
    if flat.masked is not None:
        full = res["views"]["full"]
        full["masked_pixels"] = int(flat.masked.mask.sum())
        full["level_masked"] = masked_level(flat.masked, full["level"])
        if dark is None:
            full["components_masked"] = _components(flat.masked, None)
        elif dark.masked is not None:
            full["components_masked"] = _components(flat.masked, dark.masked)
            full["dark_level_masked"] = masked_level(dark.masked, full["dark_level"])
    full = flat.acc["full"]
    arrays = {"mean": full.mean_map().astype(np.float32),
              "variance": full.temporal_var_map().astype(np.float32),
              "frame_means": np.asarray(full.frame_means(), dtype=np.float64)}
    if dark is not None:
        arrays["dark_mean"] = dark.acc["full"].mean_map().astype(np.float32)
    if flat.series is not None:  # the RTS candidates' time series (the defects analysis reads it)
        arrays.update(rts_rows=flat.series.rows.astype(np.int32), rts_cols=flat.series.cols.astype(np.int32),
                      rts_series=flat.series.series.astype(np.float32))
    for k, h in flat.hist.items():
        arrays[f"hist_{k}"] = h  # code histogram (only when the scan asks for adc_linearity)
    for k, g in flat.hist_groups.items():  # an ADC ramp's: the same as sub-histograms (the groups frames reached)
        arrays[f"histgroups_{k}"] = g[: min(g.shape[0], flat.n_frames)]
    for prefix, stack in (("", flat), ("dark_", dark)):
        arrays.update(frame_meta_arrays(stack, prefix) if stack is not None else {})
    return res, arrays


def frame_meta_arrays(stack: StackSet, prefix: str = "") -> dict:
    """Per-frame metadata of a stack as arrays (``frame_counter``, ``frame_timestamp``,
    ``frame_temperature``, ``frame_device_timestamp`` when any frame carried one); none when the
    stack recorded none."""
    if not stack.frame_meta:
        return {}
    counter, stamp, temp, dev = (np.asarray(c) for c in zip(*stack.frame_meta))
    out = {f"{prefix}frame_counter": counter.astype(np.int64), f"{prefix}frame_timestamp": stamp.astype(np.float64)}
    if np.isfinite(temp).any():
        out[f"{prefix}frame_temperature"] = temp.astype(np.float64)
    if np.isfinite(dev).any():  # the device's time stamps (GenTL timestamp_ns), beside the host's arrival times
        out[f"{prefix}frame_device_timestamp"] = dev.astype(np.float64)
    return out


FULL = (slice(None), slice(None))


BATCH_BYTES = 64 << 20  # an accumulator's batch store (copied 16-bit frames) stays below this
