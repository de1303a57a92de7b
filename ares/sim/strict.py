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
    """A level that relaxes to its set point with time constant ``tau_s`` on ``clock``."""

    def __init__(self, clock: SimClock, tau_s: float, level: float = 0.0):
        if not (math.isfinite(tau_s) and tau_s >= 0):
            raise ValueError(f"light time constant {tau_s!r} s must be finite and >= 0")
        self.clock, self.tau_s = clock, float(tau_s)
        self._from = self._to = float(level)
        self._t0 = clock.now()

    def set(self, level: float) -> None:
        self._from = self.level_at(self.clock.now())
        self._to, self._t0 = float(level), self.clock.now()

    def level_at(self, t: float) -> float:
        if self.tau_s == 0 or t <= self._t0:
            return self._to if self.tau_s == 0 else self._from
        return self._to + (self._from - self._to) * math.exp(-(t - self._t0) / self.tau_s)


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
