"""Device behaviours of a real bench the simulated one can be made to show, on a simulated clock.

* ``SimClock``: the bench's time. Frames advance it by their exposure; a wait on it
  (``sleep``) advances it at once, so settling tests run in no wall time.
* ``SettlingLight``: the light's level approaches a new set point with a first-order time
  constant ``tau_s`` (an LED's thermal drift, a lamp's warm-up): ``level_at(t)``.
* ``Pipeline``: a sensor whose next ``lag_frames`` frames after a register change are still
  exposed at the old settings (the frames already in the readout pipeline), and tagged
  with the settings they really had (as a device's chunk data would be).

Faults/behaviours of ``ares.sim.bench.SimFrameSource``: ``{"light_tau_s": 0.3,
"pipeline_lag_frames": 2}``."""

from __future__ import annotations

import bisect
import math
import time


class SimClock:
    """Simulated seconds: ``now()``; ``sleep(s)`` advances it (no wall time passes)."""

    def __init__(self, t: float = 0.0):
        self.t = float(t)

    def now(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += max(0.0, float(seconds))

    def advance(self, seconds: float) -> None:
        self.t += max(0.0, float(seconds))


class WallClock:
    """The host's monotonic clock, with the same interface as ``SimClock``."""

    @staticmethod
    def now() -> float:
        return time.monotonic()

    @staticmethod
    def sleep(seconds: float) -> None:
        time.sleep(max(0.0, float(seconds)))


class SettlingLight:
    """A level that relaxes to its set point with time constant ``tau_s`` on ``clock`` (0: a step).
    Every change is kept (the latest ``HISTORY``), so the level is known at any time since --
    ``level_at(t)`` -- and over a frame's own exposure window: ``mean(t0, t1)``, the time-weighted
    level a pixel integrates (part old, part new when a change falls inside the window)."""

    HISTORY = 256

    def __init__(self, clock: SimClock, tau_s: float, level: float = 0.0):
        if not (math.isfinite(tau_s) and tau_s >= 0):
            raise ValueError(f"light time constant {tau_s!r} s must be finite and >= 0")
        self.clock, self.tau_s = clock, float(tau_s)
        self._segs = [(clock.now(), float(level), float(level))]  # (since, from, to): one per change
        self._starts = [self._segs[0][0]]

    def set(self, level: float) -> None:
        t = self.clock.now()
        start = self.level_at(t)
        while len(self._segs) > 1 and self._starts[-1] >= t:  # set again at the same instant: replaces
            self._segs.pop()
            self._starts.pop()
        self._segs.append((t, start, float(level)))
        self._starts.append(t)
        if len(self._segs) > self.HISTORY:
            del self._segs[0], self._starts[0]

    def _seg(self, t: float) -> tuple:
        i = bisect.bisect_right(self._starts, t) - 1
        return self._segs[max(i, 0)] if i >= 0 else (t, self._segs[0][1], self._segs[0][1])

    def level_at(self, t: float) -> float:
        t0, a, b = self._seg(t)
        if self.tau_s == 0 or t <= t0:
            return b if self.tau_s == 0 else a
        return b + (a - b) * math.exp(-(t - t0) / self.tau_s)

    def mean(self, t0: float, t1: float) -> float:
        """The time-weighted level over [t0, t1] (the level at t0 for an empty window)."""
        if not t1 > t0:
            return self.level_at(t0)
        i = max(bisect.bisect_right(self._starts, t0) - 1, 0)
        j = bisect.bisect_left(self._starts, t1)
        if j - i <= 1 and self.tau_s == 0:  # one step level over the whole window: exactly it
            return self.level_at(t0)
        edges = [t0] + [u for u in self._starts[i + 1:j] if t0 < u < t1] + [t1]
        total = 0.0
        for u0, u1 in zip(edges, edges[1:]):
            s, a, b = self._seg(u0)
            if self.tau_s == 0:
                total += b * (u1 - u0)
            else:  # b + (a - b) exp(-(t - s) / tau), integrated from u0 to u1
                tau = self.tau_s
                total += b * (u1 - u0) + (a - b) * tau * (math.exp(-(u0 - s) / tau) - math.exp(-(u1 - s) / tau))
        return total / (t1 - t0)


# the settings a register change moves (the light and the temperature are the instruments')
REGISTER_SETTINGS = ("exposure_s", "analog_gain", "black_level_dn", "read_noise_scale", "dark_current_scale",
                     "lag_scale")


class Pipeline:
    """The settings each frame is really exposed with, ``lag_frames`` frames behind a change."""

    def __init__(self, lag_frames: int):
        if lag_frames < 0:
            raise ValueError(f"pipeline lag {lag_frames!r} frames must be >= 0")
        self.lag = int(lag_frames)
        self._active: dict | None = None  # what the frames are exposed with
        self._target: dict | None = None  # what the registers ask for
        self._left = 0

    def frame_settings(self, requested: dict) -> dict:
        """The register part of the next frame's settings (``requested``: the registers now)."""
        want = {k: requested[k] for k in REGISTER_SETTINGS if k in requested}
        if self._active is None:  # the first frames ever: the registers as they are
            self._active = self._target = want
        elif want != self._target:
            self._target, self._left = want, self.lag
        if self._left > 0:
            self._left -= 1
        else:
            self._active = self._target
        return dict(self._active)
