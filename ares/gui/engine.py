"""Adapter between the scan engine and the GUI (no Qt).

A *job* is anything with ``run(emit)`` (blocking; calls ``emit(event)`` with
``ares.gui.events`` objects, raises ``AresError`` on user-caused failures) and
``pause()``, ``resume()``, ``stop()`` (finish the stage in flight, keep it) and
``abort()`` (drop the stage in flight). ``ares.gui.worker`` runs a job in a Python thread.

``open_scan(path)`` builds a job for a scan XML through the real runner
(``ares.scan``) when it is installed; ``DemoScan`` is a built-in photon-transfer sweep
on a tiny simulated sensor so the window works (and is tested) on its own.
"""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path
from typing import Callable, Protocol

import numpy as np

from ares.errors import InputError, Interrupted

from ares.gui.events import Done, FramePreview, Progress, RunInfo, StageResult, StageStarted, Stopped

Emit = Callable[[object], None]


class Job(Protocol):
    title: str
    info: dict

    def run(self, emit: Emit) -> None: ...
    def pause(self) -> None: ...
    def resume(self) -> None: ...
    def stop(self) -> None: ...
    def abort(self) -> None: ...


class JobControl:
    """Pause/stop/abort flags a job checks between frames (thread-safe)."""

    def __init__(self) -> None:
        self._running = threading.Event()
        self._running.set()
        self.stopping = False
        self.aborting = False

    def pause(self) -> None:
        self._running.clear()

    def resume(self) -> None:
        self._running.set()

    def stop(self) -> None:
        self.stopping = True
        self._running.set()

    def abort(self) -> None:
        self.aborting = True
        self._running.set()

    @property
    def paused(self) -> bool:
        return not self._running.is_set()

    def checkpoint(self) -> None:
        """Block while paused; raise ``Interrupted`` on abort."""
        self._running.wait()
        if self.aborting:
            raise Interrupted("aborted by the user; the stage in flight was dropped")


class DemoScan(JobControl):
    """A built-in photon-transfer sweep: one dark stage, then rising light levels, on a
    small simulated sensor. Uses ``ares.sim.SimSensor`` when available, otherwise a
    plain offset + gain + read-noise + shot-noise model."""

    def __init__(self, shape: tuple[int, int] = (48, 64), frames: int = 4,
                 levels_e: tuple[float, ...] = (0, 50, 200, 800, 3200),
                 gain_dn_per_e: float = 0.5, offset_dn: float = 100.0,
                 read_noise_dn: float = 2.0, seed: int = 0, frame_delay_s: float = 0.0) -> None:
        super().__init__()
        self.shape, self.frames, self.levels_e = tuple(shape), int(frames), tuple(levels_e)
        self.gain, self.offset, self.read_noise = gain_dn_per_e, offset_dn, read_noise_dn
        self.seed, self.frame_delay_s = seed, frame_delay_s
        self.title = "built-in demo: photon transfer on a simulated sensor"
        self.info = {
            "scan": self.title,
            "system": f"simulated sensor {shape[1]} x {shape[0]} (built-in demo model)",
            "frames per stage": str(frames),
        }

    def _frames(self, rng: np.random.Generator, level_e: float, n: int):
        rows, cols = self.shape
        prnu = self._prnu
        for _ in range(n):
            electrons = rng.poisson(level_e * prnu).astype(np.float64) if level_e > 0 else 0.0
            v = self.offset + self._dsnu + self.gain * electrons + rng.normal(0, self.read_noise, self.shape)
            yield np.clip(np.rint(v), 0, 4095).astype(np.uint16)

    def run(self, emit: Emit) -> None:
        rng = np.random.default_rng(self.seed)
        self._prnu = 1 + 0.01 * rng.standard_normal(self.shape)
        self._dsnu = 1.0 * rng.standard_normal(self.shape)
        total = len(self.levels_e)
        t0 = time.monotonic()
        emit(RunInfo(None, total, None))
        dark_mean = dark_var = None
        for k, level in enumerate(self.levels_e):  # k: the stage index, from 0 as in the files
            if self.stopping:
                emit(Stopped("Stopped after %d of %d stages; completed stages are kept." % (k, total)))
                return
            name = "dark" if level == 0 else f"{level:g} e-"
            emit(StageStarted(k, total, name, self.frames, {"light_e": level}))
            acc_sum = np.zeros(self.shape, np.float64)
            acc_sq = np.zeros(self.shape, np.float64)
            for f, frame in enumerate(self._frames(rng, level, self.frames), start=1):
                self.checkpoint()
                if self.frame_delay_s:
                    time.sleep(self.frame_delay_s)
                d = frame.astype(np.float64) - self.offset  # shifted: exact enough in float64
                acc_sum += d
                acc_sq += d * d
                emit(FramePreview(k, f, self.frames, frame))
                done = (k + f / self.frames) / total
                elapsed = time.monotonic() - t0
                emit(Progress(k, total, done, elapsed * (1 - done) / done if done > 0 else None))
            n = self.frames
            mean = acc_sum / n
            var = (acc_sq - n * mean * mean) / (n - 1) if n > 1 else np.full(self.shape, math.nan)
            point = None
            if level == 0:
                dark_mean, dark_var = float(mean.mean()), float(np.nanmean(var))
            elif dark_mean is not None:
                point = (float(mean.mean()) - dark_mean, float(np.nanmean(var)) - dark_var)
            quantities = {"mean output (DN, offset included)": float(mean.mean()) + self.offset,
                          "temporal noise (DN)": math.sqrt(max(float(np.nanmean(var)), 0.0))}
            emit(StageResult(k, name, mean + self.offset, var, n, dark=(level == 0),
                             settings={"light_e": level}, ptc_point=point, ptc_view="full",
                             group="light sweep", coords=(k,), quantities=quantities))
        emit(Done(None, {"pixels": int(np.prod(self.shape))}))


def open_scan(path: str | Path, regions=None, output=None, system: str | None = None,
              frames: int | None = None) -> Job:
    """A job for the scan XML at ``path``, run through ``ares.scan`` on the bench its
    system XML declares (the simulated bench by default). ``regions``: the RoA table's
    active rows, which replace the scan's regions in what runs and what the run saves;
    ``output``: an ``ares.protocol.Output`` replacing the scan's ``<output>``; ``system``: a
    system XML instead of the scan's ``<system href>`` (as ``ares run --system``); ``frames``:
    every stage's frame count (as ``ares run --frames``; None: the scan's own)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such scan file.")
    try:
        from ares.gui import runner_adapter
    except ImportError:
        raise InputError(f"{path}: the scan runner (ares.scan) is not available in this installation.") from None
    return runner_adapter.RunnerJob(path, frames=frames, regions=regions, output=output, system=system)
