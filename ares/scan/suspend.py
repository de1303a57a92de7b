"""Suspenders: a scan's ``<suspend>`` conditions pause acquisition while the bench is out of
tolerance (the chamber drifted off its set point, the light source's output moved) and
resume it by itself when they have cleared.

The runner checks the conditions when a stack starts and then at most every ``poll_s``
while frames arrive. A failed check raises ``Suspended``; the runner drops the frames of
the stage in flight (they may have been taken out of tolerance), waits here until every
condition has held for ``hold_s``, and acquires the stage again. Each pause is recorded in
the stage's JSON (``suspensions``: reason, device, attempts, seconds). A ``device``
condition does the same when a device is unplugged or stops answering (``DeviceGone``):
the bench reopens the device that failed (``DeviceGone.device``: frame source, register
bus, light source or chamber -- never another), first after ``poll_s`` and then with the
pause doubled each attempt up to ``BACKOFF_CAP`` x ``poll_s``; when it is back every
setting is applied again. Bounded: a pause longer than ``timeout_s`` is a hardware error
naming the condition, and so is a stage paused more than ``max_recoveries`` times (a device
that comes back only to fail again); a stop or abort ends the wait within 0.1 s.
"""

from __future__ import annotations

import time

from ares.errors import DeviceGone, HardwareError
from ares.hardware.waits import Interrupted, wait

BACKOFF_CAP = 16  # the longest pause between reconnect attempts, in poll_s


def light_readback(light) -> float:
    """What the light source measures it gives (``read_level``: its monitor); a source that can
    only echo its set point cannot be checked, and saying it is in tolerance would be a lie."""
    read = getattr(light, "read_level", None)
    got = read() if read is not None else None
    if got is None:
        raise HardwareError(f"{light.name}: the <suspend> light condition needs a readback of the light's output "
                            "(a 'read' command in its <protocol>, e.g. its monitor photodiode); 'get' only "
                            "answers the set point")
    return float(got)


class Suspended(Exception):
    """A condition is out of tolerance: the stage in flight must be acquired again."""

    def __init__(self, reason: str, settings: dict):
        super().__init__(reason)
        self.reason, self.settings = reason, settings


class Suspenders:
    def __init__(self, spec, bench, cancel=None, *, clock=time.monotonic, sleep=time.sleep):
        self.spec, self.bench, self.cancel = spec, bench, cancel
        self._clock, self._sleep = clock, sleep
        self._last = None

    def violation(self, settings: dict) -> str | None:
        """One sentence for the first condition out of tolerance at ``settings``, else None."""
        for q, tol in self.spec.conditions:
            if q == "temperature" and "temperature" in settings and self.bench.chamber is not None:
                want, got = settings["temperature"], self.bench.chamber.get_temperature()
                if not abs(got - want) <= tol:
                    return f"chamber at {got:g} C, set point {want:g} +/- {tol:g} C"
            elif q == "light" and settings.get("light") and self.bench.light is not None:
                want, got = settings["light"], light_readback(self.bench.light)  # its output, not its set point
                if not abs(got - want) <= tol * abs(want):
                    return f"light level reads back {got:.6g}, set {want:.6g} +/- {100 * tol:g} %"
        return None

    def check(self, settings: dict, force: bool = False) -> None:
        """Raise ``Suspended`` when a condition fails; polled at most every ``poll_s``."""
        now = self._clock()
        if not force and self._last is not None and now - self._last < self.spec.poll_s:
            return
        self._last = now
        why = self.violation(settings)
        if why:
            raise Suspended(why, settings)

    @property
    def handles_devices(self) -> bool:
        """A ``device`` condition: devices that fail are waited for and reopened."""
        return any(q == "device" for q, _ in self.spec.conditions)

    def handles(self, exc: Exception) -> bool:
        """A failed condition always; an unplugged frame source with a ``device`` condition."""
        return isinstance(exc, Suspended) or (isinstance(exc, DeviceGone)
                                              and any(q == "device" for q, _ in self.spec.conditions))

    def wait_out(self, exc: Exception, stage: str, earlier: int = 0) -> dict:
        """Wait until the cause of ``exc`` has cleared; the pause as a record. ``earlier``:
        the stage's pauses so far -- past ``max_recoveries`` the run fails instead."""
        limit = self.spec.max_recoveries
        if earlier >= limit:
            raise HardwareError(f"stage '{stage}': {exc} -- again after {earlier} recover{'y' if earlier == 1 else 'ies'}"
                                f" (max_recoveries={limit} of <suspend> in the scan)")
        if self.cancel is not None and self.cancel():
            raise Interrupted
        if isinstance(exc, Suspended):
            return self.wait_clear(exc.settings, exc.reason, stage)
        return self.wait_reconnect(str(exc), stage, getattr(exc, "device", "frames"))

    def wait_reconnect(self, reason: str, stage: str, device: str = "frames") -> dict:
        """``device`` was unplugged or stopped answering: reopen it (that one only) with a
        growing pause between attempts until it is back (the pause as a record) or
        ``timeout_s`` has passed (``DeviceGone``)."""
        t0, started, attempts = self._clock(), time.time(), 0
        pause = self.spec.poll_s
        while True:
            try:
                attempts += 1
                self.bench.reconnect(device)
                return {"stage": stage, "reason": reason, "device": device, "attempts": attempts,
                        "started": started, "seconds": round(self._clock() - t0, 3)}
            except DeviceGone as exc:
                if self._clock() - t0 >= self.spec.timeout_s:
                    raise DeviceGone(f"stage '{stage}': {reason}; not back after {self.spec.timeout_s:g} s and "
                                     f"{attempts} attempt(s) ({exc}; timeout_s of <suspend> in the scan)",
                                     device) from None
            left = self.spec.timeout_s - (self._clock() - t0)
            wait(max(0.0, min(pause, left)), self.cancel, sleep=self._sleep, clock=self._clock)
            pause = min(2 * pause, BACKOFF_CAP * self.spec.poll_s)

    def wait_clear(self, settings: dict, reason: str, stage: str) -> dict:
        """Wait until every condition has held ``hold_s``; the pause as a record."""
        t0, started, held = self._clock(), time.time(), None
        while True:
            why = self.violation(settings)
            now = self._clock()
            held = (held if held is not None else now) if why is None else None
            if held is not None and now - held >= self.spec.hold_s:
                return {"stage": stage, "reason": reason, "started": started, "seconds": round(now - t0, 3)}
            if now - t0 >= self.spec.timeout_s:
                raise HardwareError(f"stage '{stage}': suspended for {self.spec.timeout_s:g} s and the condition did "
                                    f"not clear ({why}; timeout_s of <suspend> in the scan)")
            wait(self.spec.poll_s, self.cancel, sleep=self._sleep, clock=self._clock)
