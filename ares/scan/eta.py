"""Time remaining from what the run has measured: seconds per frame (inside the frame
loops, the latest stack's rate) and seconds per stage outside them (settling, the stage's analysis and its write),
instead of frames left / overall frame rate -- which counts none of a stage's end work
before the first stage has ended, and so reads 40-60 % low early in a scan. The per-stage
time is the median over the finished stages, so the first stage's one-off work (imports,
the defect mask) does not inflate every later estimate.

``Eta`` is fed event times by the runner and knows nothing of clocks itself (tests give
it made-up times)."""

from __future__ import annotations

import statistics


class Eta:
    def __init__(self, frames_total: int, stages_total: int, prior_s: float = 0.0):
        self.frames_total = frames_total
        self.stages_total = stages_total
        self.prior_s = prior_s  # the hardware-time estimate, used until something is measured
        self.t_frames = 0.0  # seconds between consecutive frames of a stack
        self.n_frames = 0  # frame intervals those seconds cover
        self.frames_done = 0
        self.overheads: list[float] = []  # per finished stage: its time outside the frame loops
        self._per_stage = 0.0  # their median, updated when a stage ends (remaining() runs per frame)
        self._last: float | None = None  # time of the previous frame in the current stack
        self._stack = [0.0, 0]  # frame-loop seconds and intervals of the current stack
        self._prev_stack: tuple[float, int] | None = None  # ... of the previous stack
        self._stage_t0: float | None = None  # when the current stage started
        self._stage_frames = 0.0  # frame-loop seconds of the current stage

    def stage_started(self, t: float) -> None:
        """A stack of the current stage starts at ``t`` (a stage may grab a dark and a flat)."""
        if self._stage_t0 is None:
            self._stage_t0 = t
        if self._stack[1]:
            self._prev_stack = (self._stack[0], self._stack[1])
        self._stack = [0.0, 0]
        self._last = None

    def frame(self, t: float) -> None:
        if self._last is not None:
            self.t_frames += t - self._last
            self._stage_frames += t - self._last
            self.n_frames += 1
            self._stack[0] += t - self._last
            self._stack[1] += 1
        self._last = t
        self.frames_done += 1

    def stage_finished(self, t: float) -> None:
        if self._stage_t0 is not None:
            self.overheads.append(max(t - self._stage_t0 - self._stage_frames, 0.0))
            self._per_stage = statistics.median(self.overheads)
        self._stage_t0, self._stage_frames, self._last = None, 0.0, None

    def remaining(self, t: float) -> float | None:
        """Seconds left at ``t``: frames left x s/frame + stages not finished x s/stage, less
        what the current stage has already spent outside its frame loop."""
        if self.n_frames == 0:
            return self.prior_s or None
        # the latest frame rate: the current stack once it has a few frames, else the previous
        # one (the first stacks run slower: warm-up, the dark stage kept for the defect mask)
        if self._stack[1] >= 4 or self._prev_stack is None:
            sec, n = self._stack if self._stack[1] else (self.t_frames, self.n_frames)
        else:
            sec, n = self._prev_stack
        per_frame = sec / n
        left = (self.frames_total - self.frames_done) * per_frame
        if not self.overheads:
            return left  # no stage has ended yet: its end work is not known
        per_stage = self._per_stage
        spent = 0.0
        if self._stage_t0 is not None:
            spent = max(t - self._stage_t0 - self._stage_frames, 0.0)
        return left + max((self.stages_total - len(self.overheads)) * per_stage - spent, 0.0)
