"""Settling by evidence (``<timing><settle>``, ``ares.protocol.settle``): after a change the
bench is settled when its frames say so, and every stack is checked for a trend or a step.

A frame is summarised by its row and column means (``FrameStats``). Two frames agree when
the difference of their means is within ``k`` standard errors -- the standard error from
the differences of their row means and of their column means, so row and column temporal
noise count -- or within ``rtol`` of the level, whichever is wider (a statistically
significant but negligible difference on a 12-megapixel frame is no reason to wait).
Frames a device tags with their exposure/gain (``Frame.meta`` ``exposure_s``,
``analog_gain``) must carry the settings asked for."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.errors import FrameError
from ares.hardware.waits import wait


@dataclass
class FrameStats:
    rows: np.ndarray  # mean of each row (DN)
    cols: np.ndarray  # mean of each column (DN)

    @classmethod
    def of(cls, data: np.ndarray) -> "FrameStats":
        d = np.asarray(data)
        if d.ndim != 2:
            d = d.reshape(d.shape[0], -1)
        return cls(d.mean(axis=1, dtype=np.float64), d.mean(axis=0, dtype=np.float64))

    @property
    def mean(self) -> float:
        return float(self.rows.mean())


def pair_se(a: FrameStats, b: FrameStats) -> float:
    """Standard error of ``b.mean - a.mean`` from the two frames' temporal noise (conservative:
    pixel noise is counted in both the row and the column term)."""
    dr, dc = b.rows - a.rows, b.cols - a.cols
    var = (dr.var(ddof=1) / dr.size if dr.size > 1 else 0.0) + (dc.var(ddof=1) / dc.size if dc.size > 1 else 0.0)
    return math.sqrt(var)


class FrameNoise:
    """What two frames cannot tell about their own noise: the variance of a difference of
    frame means from whole-frame noise (flicker, clamp drift), learned from the run's stacks
    (the robust scatter of consecutive frame means beyond what their rows and columns
    explain; the median over the stacks of >= 5 frames so far). Until the run has measured
    it, a frame's whole-frame noise is taken as large as one row's temporal noise (``prior``:
    the variance of a difference of two rows' means), a conservative guess."""

    def __init__(self):
        self.seen: list[float] = []

    @property
    def known(self) -> bool:
        return bool(self.seen)

    @property
    def var(self) -> float:
        return float(np.median(self.seen)) if self.seen else 0.0

    def extra(self, a: "FrameStats", b: "FrameStats") -> float:
        """The variance to add to ``pair_se(a, b)**2``: learned, else the prior from the pair."""
        if self.seen:
            return self.var
        return prior_var(a, b)

    def learn(self, stats: list) -> None:
        if len(stats) < 5:
            return
        m = np.array([s.mean for s in stats])
        d = np.diff(m)
        robust = 1.4826 * float(np.median(np.abs(d - np.median(d))))
        se = float(np.median([pair_se(stats[i], stats[i + 1]) for i in range(len(stats) - 1)]))
        self.seen.append(max(0.0, robust * robust - se * se))


def prior_var(a: FrameStats, b: FrameStats) -> float:
    """The variance of a difference of two rows' means (a row's temporal noise, twice)."""
    dr = b.rows - a.rows
    return float(dr.var(ddof=1)) if dr.size > 1 else 0.0


def tolerance(level: float, se: float, k: float, rtol: float) -> float:
    return max(k * se, rtol * abs(level))


def agree(a: FrameStats, b: FrameStats, k: float, rtol: float, extra_var: float = 0.0) -> tuple[bool, float, float]:
    """(agree, difference, tolerance) of two frames' means; ``extra_var``: ``FrameNoise.extra``."""
    d = b.mean - a.mean
    tol = tolerance(max(abs(a.mean), abs(b.mean)), math.sqrt(pair_se(a, b) ** 2 + extra_var), k, rtol)
    return abs(d) <= tol, d, tol


def tags_match(meta: dict, want: dict) -> bool | None:
    """Whether a frame's tags carry the settings asked for (``want``: ``exposure_s``/
    ``analog_gain`` as the registers hold them); None when the frame has no tags."""
    seen = False
    for key, value in want.items():
        tag = (meta or {}).get(key)
        if tag is None:
            continue
        seen = True
        if not math.isclose(float(tag), float(value), rel_tol=1e-6, abs_tol=1e-12):
            return False
    return True if seen else None


def settle_by_frames(bench, cfg, want_tags, cancel=None, noise: FrameNoise | None = None) -> dict:
    """Grab probe frames ``cfg.probe_s`` apart (each gap ``cfg.growth`` times the last) until
    ``cfg.agree`` consecutive pairs agree (and tagged frames carry ``want_tags``: a dict, or a
    callable giving it, called only when a frame carries tags), or the cap. Tags alone are
    not proof: a light or a temperature changed with the registers, and a device that tags
    its frames settles as one that does not (the same frames behind the wires as on the
    simulator). ``cancel``: ends the waits (``Interrupted``). The record: frames discarded,
    bench seconds waited, settled or not and why."""
    clock = getattr(bench, "clock", None)
    now = clock.now if clock is not None else _monotonic
    t0 = now()
    frames, run, prev = 0, 0, None
    why, last = "", None
    by = "frames"
    while True:
        frame = _grab1(bench)
        frames += 1
        tagged = any(k in (frame.meta or {}) for k in ("exposure_s", "analog_gain"))
        if tagged and callable(want_tags):  # the registers read once, and only for a device that tags
            want_tags = want_tags()
        match = tags_match(frame.meta, want_tags) if tagged else None
        if match is False:
            prev, run, why = None, 0, "frames tagged with the old settings"
        else:
            if match:
                by = "tags+frames"
            st = FrameStats.of(frame.data)
            if prev is not None:
                ok, d, tol = agree(prev, st, cfg.k, cfg.rtol, noise.extra(prev, st) if noise is not None else 0.0)
                last = (d, tol)
                run = run + 1 if ok else 0
                if not ok:
                    why = f"consecutive frame means differ by {d:+.3g} DN (tolerance {tol:.3g} DN)"
            prev = st
            if run >= cfg.agree:
                return _record(True, frames, now() - t0, by, f"{run} consecutive frame pairs agree" +
                               (f" (last {last[0]:+.3g} DN, tolerance {last[1]:.3g} DN)" if last else ""))
        if now() - t0 >= cfg.max_s or frames >= cfg.max_frames:
            return _record(False, frames, now() - t0, by, f"not settled after {frames} frames and "
                           f"{now() - t0:.3g} s: {why or 'too few frames agree'}")
        gap = min(cfg.probe_s * cfg.growth ** (frames - 1), max(cfg.max_s - (now() - t0), 0.0))
        if gap > 0:  # longer and longer gaps: a slow drift shows as its whole remaining change
            if clock is not None:
                wait(gap, cancel, sleep=clock.sleep, clock=clock.now)
            else:
                wait(gap, cancel)


def _grab1(bench):
    got = list(bench.frames.grab(1))  # (run to its end: a source counts frames after a yield)
    if not got:
        raise FrameError(f"{bench.frames.name}: delivered no frame while the bench settled")
    return got[0]


def _monotonic() -> float:
    import time

    return time.monotonic()


def _record(settled: bool, frames: int, seconds: float, by: str, why: str) -> dict:
    return {"settled": settled, "probe_frames": frames, "probe_s": round(float(seconds), 6), "by": by, "why": why}


def stack_verdict(stats: list[FrameStats], k: float, rtol: float, noise: FrameNoise | None = None) -> dict | None:
    """A stack's frames checked for a step (two consecutive means that disagree) and a trend
    (a fitted slope whose change over the stack exceeds the tolerance and ``k`` of its own
    standard error). None when the stack is steady; else what was found. The standard
    error of a difference: its rows' and columns' noise, the run's whole-frame noise
    (``noise``) and, with >= 5 frames, the robust scatter of the stack's own differences."""
    n = len(stats)
    if n < 2:
        return None
    m = np.array([s.mean for s in stats])
    se = float(np.median([pair_se(stats[i], stats[i + 1]) for i in range(n - 1)]))
    extra = noise.var if noise is not None and noise.known else float(np.median(
        [prior_var(stats[i], stats[i + 1]) for i in range(n - 1)]))
    se = math.sqrt(se * se + extra)
    if n >= 5:
        dd = np.diff(m)
        se = max(se, 1.4826 * float(np.median(np.abs(dd - np.median(dd)))))
    level = float(np.abs(m).max())
    d = np.diff(m)
    # a step: robust to the trend, k standard errors of a difference and the relative floor
    tol = tolerance(level, se, k + 1.0, rtol)  # (k + 1: n - 1 pairs are compared)
    j = int(np.argmax(np.abs(d)))
    if abs(d[j]) > tol:
        return {"kind": "step", "at_frame": j + 1, "change_dn": float(d[j]), "tolerance_dn": float(tol),
                "means_dn": [round(float(x), 3) for x in m[:50]]}
    if n >= 3:
        x = np.arange(n) - (n - 1) / 2
        b = float((x * (m - m.mean())).sum() / (x * x).sum())
        resid = m - m.mean() - b * x
        s_b = math.sqrt(max(float((resid ** 2).sum()) / (n - 2), se * se / 2) / float((x * x).sum()))
        drift = b * (n - 1)
        tol = max(k * s_b * (n - 1), rtol * level)
        if abs(drift) > tol:
            return {"kind": "trend", "change_dn": drift, "tolerance_dn": float(tol),
                    "means_dn": [round(float(v), 3) for v in m[:50]]}
    return None
