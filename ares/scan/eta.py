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

A stack may also carry a relative cost of its frames (``FrameSource.frame_cost``: the
simulator's frame costs what its path costs, not the exposure: exact Poisson at low
light 1.7x a Gaussian draw, so make run's 11 low-light stages would charge the 14
brighter ones after them 1.4x their time). Rates are then kept per kind and cost. A
source that also counts the seconds it spends making frames (``compute_seconds``: the
simulator) lets a stack whose cost has not been timed yet be charged in two parts: the
source's seconds per unit of cost, from its latest stacks, times the stack's cost, plus
the rest of a frame's time (accumulating it, previews, the previous stage's analysis
beside it) as its kind's latest stacks took it.

``Eta`` is fed event times by the runner and knows nothing of clocks itself (tests give
it made-up times)."""

from __future__ import annotations

import logging
import math
import statistics
from collections import deque

from ares.errors import AresError
from ares.scan.apply import as_fields
from ares.scan.stages import frame_seconds

log = logging.getLogger(__name__)


KEEP = 6  # stacks a rate is the median of


class Eta:
    def __init__(self, frames_total: int, stages_total: int, prior_s: float = 0.0,
                 stacks: list[tuple] | None = None, stages_by_scene: dict[str, int] | None = None):
        """``stacks``: the scan's stacks in order, (kind, frames, model seconds of a frame[,
        relative cost of a frame, default 1]); else ``frames_total`` frames of one kind
        without a model."""
        self.frames_total = frames_total
        if stacks is None:
            stacks = [("", frames_total, 0.0)]
        self.left: dict[str, deque] = {}  # kind -> [frames, model s, relative cost] of its stacks to come
        self._totals: dict[str, dict] = {}  # kind -> (model s, relative cost) -> frames to come
        for kind, n, cost, *weight in stacks:
            self.left.setdefault(kind, deque())
            totals = self._totals.setdefault(kind, {})
            if n > 0:
                key = (float(cost), float(weight[0]) if weight else 1.0)
                self.left[kind].append([n, *key])
                totals[key] = totals.get(key, 0) + n
        self.kind = next(iter(self.left), "")  # (no stack left: a resume after the last stage)
        self._cost = 0.0  # model seconds of a frame of the current stack
        self._weight = 1.0  # ... and its relative cost
        # finished stacks, their latest six: s/frame beyond the model by (kind, cost) and its median;
        # those the source timed as (kind, cost, s beyond, the source's s), and their rest by kind
        self._by_key: dict[tuple, deque] = {}
        self._points: dict[tuple, float] = {}
        self._timed: deque = deque(maxlen=KEEP)
        self._rest: dict[str, deque] = {}
        self._last_rate = 0.0  # the latest finished stack's s/frame beyond its model
        self.stages_total = stages_total
        self.prior_s = prior_s  # the hardware-time estimate, used until something is measured
        self.n_frames = 0  # frame intervals timed
        self.overheads: list[float] = []  # per finished stage: its time outside the frame loops
        # ... of the latest three stages after the run's first, with their time after their frames:
        # by scene (a dark stage's analysis is lighter than a flat's) and of any scene
        self._recent: dict[str, deque] = {}
        self._recent_any: deque = deque(maxlen=3)
        self._first_after = 0.0  # the run's first stage's time after its frames
        self.stages_left = dict(stages_by_scene or {"": stages_total})
        self._last: float | None = None  # time of the previous frame in the current stack
        self._stack = [0.0, 0]  # frame-loop seconds and intervals of the current stack
        self._compute = [None, None]  # the source's seconds making frames at the stack's first frame, its latest
        self._stage_t0: float | None = None  # when the current stage started
        self._t_end: float | None = None  # when the previous stage ended
        self._stage_frames = 0.0  # frame-loop seconds of the current stage
        self._one_off = 0.0  # ... and seconds of one-off work in it (the defect mask)
        self.commits: list[float] = []  # seconds of the latest stages' analysis and write
        self._scene = ""  # the current stage's scene

    def stage_started(self, t: float, kind: str | None = None, scene: str | None = None) -> None:
        """A stack of the current stage starts at ``t`` (a stage may grab a dark and a flat);
        ``kind`` is one of the ``stacks``' kinds, ``scene`` the stage's (else its first
        stack's kind)."""
        if self._stage_t0 is None:  # the stage starts where the previous one ended: setting up,
            # settling and waiting for the previous stage's commit are this stage's work
            self._stage_t0 = t if self._t_end is None else min(self._t_end, t)
            scene = scene or (kind if kind is not None else self.kind)
            self._scene = scene if scene in self.stages_left else next(iter(self.stages_left))
        else:  # the stage's previous stack ended
            self._stage_frames += self._first_frame()
        if self._stack[1]:
            self._finished(self._stack_record())
        if kind is not None and kind in self.left:
            self.kind = kind
        pool = self.left[self.kind]
        if pool:
            self._cost, self._weight = pool[0][1], pool[0][2]
        self._stack = [0.0, 0]
        self._last = None

    def frame(self, t: float, compute: float | None = None) -> None:
        """A frame arrived at ``t``; ``compute``: the source's seconds spent making frames
        so far, where it counts them (timed from the stack's first frame on, as the
        intervals are: the first frame holds setting up the operating point)."""
        if self._last is None:
            self._compute = [compute, compute]
        else:
            self._compute[1] = compute
            self._stage_frames += t - self._last
            self.n_frames += 1
            self._stack[0] += t - self._last
            self._stack[1] += 1
        self._last = t
        pool = self.left[self.kind]
        if pool:
            pool[0][0] -= 1
            totals, key = self._totals[self.kind], tuple(pool[0][1:])
            totals[key] -= 1
            if not totals[key]:
                del totals[key]
            if pool[0][0] <= 0:
                pool.popleft()

    def one_off(self, seconds: float) -> None:
        """Work of the current stage that no later stage repeats (building the defect
        mask): not charged to the stages to come."""
        self._one_off += seconds

    def end_work(self, seconds: float) -> None:
        """A stage's analysis and write took ``seconds`` of its thread's CPU (after its
        frames, beside the next stage's: the run waits for the last stage's once its frames
        are in, when it has the cores to itself)."""
        self.commits.append(seconds)

    def _first_frame(self) -> float:
        """The current stack's first frame, taken as long as its mean interval: frames are
        timed by the intervals between them, and the wait for the first one is not stage
        work (which every later stage would be charged) but a frame."""
        if self._stack[1]:
            return self._stack[0] / self._stack[1]
        if self._last is None:  # no frame yet
            return 0.0
        return self._cost + self._rates()(self.kind, self._weight)

    def _stack_record(self) -> tuple:
        """The current stack as (kind, cost, s/frame beyond its model, the source's s/frame
        making them or None)."""
        c0, c1 = self._compute
        source = None if c0 is None or c1 is None else (c1 - c0) / self._stack[1]
        return self.kind, self._weight, self._stack[0] / self._stack[1] - self._cost, source

    def _finished(self, rec: tuple) -> None:
        kind, weight, beyond, source = rec
        keep = self._by_key.setdefault((kind, weight), deque(maxlen=KEEP))
        keep.append(beyond)
        self._points[(kind, weight)] = statistics.median(keep)
        self._last_rate = beyond
        if source is not None and weight > 0:
            self._timed.append(rec)
            self._rest.setdefault(kind, deque(maxlen=KEEP)).append(beyond - source)

    def _rates(self):
        """(kind, cost) -> seconds beyond the model a frame of a stack to come: the current
        stack's own once it has a few frames; else the median of its kind and cost's
        latest six stacks (a burst of slow ones does not swing it); else, not timed yet, by
        the source's seconds per unit cost and the rest as its kind took it (see the
        module) or, where the source does not count its seconds, the latest rate."""
        here = (self.kind, self._weight)
        points, timed, rest = self._points, list(self._timed), self._rest
        cur = self._stack_record() if self._stack[1] else None
        own = None  # the current stack's own rate, where it is the one to use
        if cur is not None and (self._stack[1] >= 4 or not self._by_key):  # (the run's first stack: all it has)
            own = cur[2]
        if cur is not None and cur[3] is not None and cur[1] > 0 and (own is not None or self.kind not in rest):
            timed.append(cur)  # (its kind's only frames yet)
            rest = {**rest, self.kind: [*rest.get(self.kind, ()), cur[2] - cur[3]]}
        if timed:
            timed = timed[-KEEP:]
            speed = statistics.median([c / w for _, w, _, c in timed])
            rest_of = {k: statistics.median(list(v)[-KEEP:]) for k, v in rest.items()}
            anyhow = statistics.median([r - c for _, _, r, c in timed])

            def guess(kind: str, weight: float) -> float:
                return rest_of.get(kind, anyhow) + weight * speed
        else:
            latest = self._last_rate if own is None else own

            def guess(kind: str, weight: float) -> float:
                return latest

        def rate(kind: str, weight: float) -> float:
            r = own if own is not None and (kind, weight) == here else points.get((kind, weight))
            return guess(kind, weight) if r is None else r
        return rate

    def stage_finished(self, t: float, scene: str | None = None) -> None:
        scene = scene if scene in self.stages_left else next(iter(self.stages_left))
        if self._stage_t0 is not None:
            frames = self._stage_frames + self._first_frame()
            after = max(t - self._last - self._one_off, 0.0) if self._last is not None else 0.0
            overhead = max(t - self._stage_t0 - frames - self._one_off, 0.0)
            if self.overheads:
                self._recent.setdefault(scene, deque(maxlen=3)).append((overhead, after))
                self._recent_any.append((overhead, after))
            else:
                self._first_after = after
            self.overheads.append(overhead)
        self.stages_left[scene] = max(self.stages_left[scene] - 1, 0)
        self._stage_t0, self._stage_frames, self._last, self._one_off = None, 0.0, None, 0.0
        self._t_end = t

    def per_stage(self, scene: str, spent: float | None = None) -> float:
        """A stage's time outside its frame loops: the median of the latest three stages of
        the same scene (a scene not timed yet: of the others), after the run's first, and
        of the current stage once its frames have begun -- its time outside them so far
        (``spent``) plus the time stages took after their frames. The run's first stages
        hold one-off work before their first frame (loading, the first operating point:
        80 ms against 5-10 ms a stage in make run; on a scan that opens with an ADC ramp,
        its first lit stage too): the current stage outvotes one such stage early on, and
        stands in alone while only the first stage has been timed."""
        same = self._recent.get(scene) or self._recent_any
        values = [v for v, _ in same]
        if spent is not None and scene == self._scene:
            values.append(spent + (statistics.median([a for _, a in same]) if same else self._first_after))
        return statistics.median(values or self.overheads)

    def remaining(self, t: float) -> float | None:
        """Seconds left at ``t``: frames left x (their model time + the measured time beyond
        it at their kind and cost) + stages not finished x s/stage, less what the current stage has already spent
        outside its frame loop."""
        if self.n_frames == 0:
            return self.prior_s or None
        rate = self._rates()
        left = sum(frames * (cost + rate(kind, weight)) for kind, totals in self._totals.items()
                   for (cost, weight), frames in totals.items())
        if not self.overheads:
            return left  # no stage has ended yet: its end work is not known
        spent = None
        if self._stage_t0 is not None and self._last is not None:
            spent = max(t - self._stage_t0 - self._stage_frames - self._first_frame(), 0.0)
        stages = sum(n * self.per_stage(sc, spent) for sc, n in self.stages_left.items() if n)
        end = statistics.median(self.commits[-3:]) if self.commits else 0.0
        return left + max(stages - (spent or 0.0), 0.0) + end


def eta_stacks(scan, stages, frames) -> list[tuple[str, int, float, float]]:
    """The stacks the stages grab, in order, as (kind, frames, model seconds of a frame,
    relative cost of a frame) for the time remaining: a dark stack and a lit one are timed
    apart; on a bench whose frames follow the exposure (``FrameSource.exposure_paced``,
    real sensors) a frame's model is exposure + readout, else none (0: the simulator
    computes its frames); a source that can tell what a frame at given settings costs it
    (``FrameSource.frame_cost``: the simulator, by its path) weighs the stacks by it, unless
    paced (its work then hides behind the exposure: a paced simulator)."""
    paced = getattr(frames, "exposure_paced", True)
    weigh = None if paced else getattr(frames, "frame_cost", None)

    def weight(settings: dict) -> float:
        nonlocal weigh
        if weigh is None:
            return 1.0
        try:
            w = float(weigh(as_fields(scan.system, settings)))
        except AresError:  # a bad setting is reported when the stage applies it
            return 1.0
        except Exception as exc:  # noqa: BLE001 -- a time estimate never stops a scan
            log.warning("frame source %s could not cost a stage's frames (%s); time remaining unweighted",
                        getattr(frames, "name", "?"), exc)
            weigh = None  # (once)
            return 1.0
        return w if math.isfinite(w) and w > 0 else 1.0

    out = []
    for st in stages:
        model = frame_seconds(scan, st) if paced else 0.0
        dark_part = st.dark_frames if st.dark_source == "grab" else 0
        out.append(("dark" if st.scene == "dark" else "flat", st.frames_to_grab() - dark_part, model,
                    weight(st.settings)))
        if dark_part:
            out.append(("dark", dark_part, model, weight(st.dark_settings)))
    return out
