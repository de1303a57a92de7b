"""Time remaining from what the run has measured: seconds per frame (inside the frame
loops, the latest stack's rate) and seconds per stage outside them (settling, the stage's analysis and its write),
instead of frames left / overall frame rate -- which counts none of a stage's end work
before the first stage has ended, and so reads 40-60 % low early in a scan. The per-stage
time is the median over the latest three finished stages after the first, so the first
stage's one-off work (imports, the defect mask) does not inflate every later estimate.

Frames are timed per kind (``dark`` and ``flat`` stacks: a simulated or real dark frame
costs less than a bright one that clips), so frames left of each kind are charged at
their own kind's latest rate -- the dark first stage no longer sets the rate of the
flats after it.

Each stack may carry a model time per frame (``stacks``): on a bench whose frames come
no faster than the exposure (real sensors), exposure + readout. What is measured is
then a frame's time beyond the model (the grabber's and the host's share), added to
each stack's model time -- so a dark-current sweep from 10 ms to 1 s exposures is
charged 1 s frames at its last stages, not the 10 ms of its first. Without a model
(0: the simulator, whose frame time does not follow the exposure) that is the whole
frame time.

``Eta`` is fed event times by the runner and knows nothing of clocks itself (tests give
it made-up times)."""

from __future__ import annotations

import statistics
from collections import deque


class Eta:
    def __init__(self, frames_total: int, stages_total: int, prior_s: float = 0.0,
                 stacks: list[tuple[str, int, float]] | None = None, stages_by_scene: dict[str, int] | None = None):
        """``stacks``: the scan's stacks in order, (kind, frames, model seconds of a frame);
        else ``frames_total`` frames of one kind without a model."""
        self.frames_total = frames_total
        if stacks is None:
            stacks = [("", frames_total, 0.0)]
        self.left: dict[str, deque] = {}  # kind -> [frames, model s a frame] of its stacks to come
        for kind, n, cost in stacks:
            self.left.setdefault(kind, deque())
            if n > 0:
                self.left[kind].append([n, float(cost)])
        self.kind = next(iter(self.left))
        self._cost = 0.0  # model seconds of a frame of the current stack
        self.rates: dict[str, list[float]] = {}  # kind -> s/frame beyond the model, its latest finished stacks
        self.stages_total = stages_total
        self.prior_s = prior_s  # the hardware-time estimate, used until something is measured
        self.t_frames = 0.0  # seconds between consecutive frames of a stack
        self.n_frames = 0  # frame intervals those seconds cover
        self.frames_done = 0
        self.overheads: list[float] = []  # per finished stage: its time outside the frame loops
        self.scenes: list[str] = []  # ... and its scene (a dark stage's analysis is lighter than a flat's)
        self.stages_left = dict(stages_by_scene or {"": stages_total})
        self._last: float | None = None  # time of the previous frame in the current stack
        self._stack = [0.0, 0]  # frame-loop seconds and intervals of the current stack
        self._prev_stack: float | None = None  # s/frame beyond the model of the previous stack
        self._stage_t0: float | None = None  # when the current stage started
        self._t_end: float | None = None  # when the previous stage ended
        self._stage_frames = 0.0  # frame-loop seconds of the current stage
        self._one_off = 0.0  # ... and seconds of one-off work in it (the defect mask)

    def stage_started(self, t: float, kind: str | None = None) -> None:
        """A stack of the current stage starts at ``t`` (a stage may grab a dark and a flat);
        ``kind`` is one of the ``stacks``' kinds."""
        if self._stage_t0 is None:  # the stage starts where the previous one ended: setting up,
            # settling and waiting for the previous stage's commit are this stage's work
            self._stage_t0 = t if self._t_end is None else min(self._t_end, t)
        else:  # the stage's previous stack ended
            self._stage_frames += self._first_frame()
        if self._stack[1]:
            beyond = self._stack[0] / self._stack[1] - self._cost
            self._prev_stack = beyond
            self.rates.setdefault(self.kind, []).append(beyond)
        if kind is not None and kind in self.left:
            self.kind = kind
        pool = self.left[self.kind]
        self._cost = pool[0][1] if pool else self._cost
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
        pool = self.left[self.kind]
        if pool:
            pool[0][0] -= 1
            if pool[0][0] <= 0:
                pool.popleft()

    def one_off(self, seconds: float) -> None:
        """Work of the current stage that no later stage repeats (building the defect
        mask): not charged to the stages to come."""
        self._one_off += seconds

    def _first_frame(self) -> float:
        """The current stack's first frame, taken as long as its mean interval: frames are
        timed by the intervals between them, and the wait for the first one is not stage
        work (which every later stage would be charged) but a frame."""
        if self._stack[1]:
            return self._stack[0] / self._stack[1]
        if self._last is None:  # no frame yet
            return 0.0
        beyond = self.rates.get(self.kind, [self._prev_stack])[-1]  # one frame only: the latest stack's
        return self._cost + (beyond or 0.0)

    def stage_finished(self, t: float, scene: str | None = None) -> None:
        scene = scene if scene in self.stages_left else next(iter(self.stages_left))
        if self._stage_t0 is not None:
            frames = self._stage_frames + self._first_frame()
            self.overheads.append(max(t - self._stage_t0 - frames - self._one_off, 0.0))
            self.scenes.append(scene)
        self.stages_left[scene] = max(self.stages_left[scene] - 1, 0)
        self._stage_t0, self._stage_frames, self._last, self._one_off = None, 0.0, None, 0.0
        self._t_end = t

    def per_stage(self, scene: str) -> float:
        """A stage's time outside its frame loops: the median of the latest three stages of
        the same scene. The run's first stage (one-off work: the defect mask) counts only
        while nothing else has been timed; a scene not timed yet takes the others' median."""
        pairs = list(zip(self.scenes, self.overheads))
        pairs = pairs[1:] or pairs
        same = [v for sc, v in pairs if sc == scene]
        return statistics.median((same or [v for _, v in pairs])[-3:])

    def remaining(self, t: float) -> float | None:
        """Seconds left at ``t``: frames left x (their model time + the measured time beyond
        it) + stages not finished x s/stage, less what the current stage has already spent
        outside its frame loop."""
        if self.n_frames == 0:
            return self.prior_s or None
        # the latest rate: the current stack once it has a few frames, else the previous
        # one (the first stacks run slower: warm-up, the dark stage kept for the defect mask)
        if self._stack[1] >= 4 or self._prev_stack is None:
            sec, n = self._stack if self._stack[1] else (self.t_frames, self.n_frames)
            latest = sec / n - self._cost
        else:
            latest = self._prev_stack
        left = 0.0
        for kind, pool in self.left.items():  # each kind at its own latest rate
            if kind == self.kind and (self._stack[1] >= 4 or kind not in self.rates):
                rate = latest
            elif kind in self.rates:  # the median of its latest three stacks: one slow stack does not swing it
                rate = statistics.median(self.rates[kind][-3:])
            else:
                rate = latest  # not measured yet: the nearest we have
            left += sum(frames * (cost + rate) for frames, cost in pool)
        if not self.overheads:
            return left  # no stage has ended yet: its end work is not known
        spent = 0.0
        if self._stage_t0 is not None:
            spent = max(t - self._stage_t0 - self._stage_frames - self._first_frame(), 0.0)
        stages = sum(n * self.per_stage(sc) for sc, n in self.stages_left.items() if n)
        return left + max(stages - spent, 0.0)
