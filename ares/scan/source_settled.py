"""Is the light on the sensor where the stage set it, once the declared settle time is over?
(``ares.scan.apply.settle``, ``<settle by="time">``; FORMAT.md, Bench dynamics.)

Under ``<settle by="time">`` the host trusts the declared waits; a source slower than declared
(an LED whose thermal tail outlasts ``settle_s``, a grating still moving) would have its
frames kept as if settled. Where the rig gives evidence, the host looks after the declared
waits:

- a light source with a monitor of its output (its ``read`` command; the simulator's
  ``read_level``) and a tolerance (``<light_source tolerance>``): the reading must be within it
  of the set point;
- a monochromator that answers when its move is complete (a ``complete`` command, IEEE 488.2
  ``*OPC?``: its ``settle`` waited on it) is settled by its own word; one that does not is read
  back (``get``: its drive's position) and must be within half its bandwidth of the set point
  (0.05 nm when it reports none).

A source not there yet is polled (the interval doubling from 1 ms, at most 0.1 s) until it is,
for at most ``<settle max_s>`` (the settling cap) -- the time waited and why are in the record;
past the cap the stage fails with one sentence naming the device. Where the rig gives no
evidence (no monitor, no tolerance), the record says settling was not verified.

The record (the stage JSON's ``settling`` -> ``sources``): per quantity ``verified`` (True/False),
``waited_s`` (beyond the declared waits), ``read`` and ``tolerance`` where read, ``why``."""

from __future__ import annotations

import math

from ares.errors import HardwareError
from ares.hardware.waits import wait

FIRST_POLL_S, MAX_POLL_S = 1e-3, 0.1
WAVELENGTH_TOL_NM = 0.05  # a monochromator that reports no bandwidth: its readback within this


def check_sources(bench, settings: dict, kinds: set, cap_s: float, cancel=None) -> dict:
    """After the declared waits: each changed source verified (waiting for it, bounded by
    ``cap_s``), or recorded as not verifiable. Returns ``{quantity: record}``."""
    out = {}
    if "light" in kinds and bench.light is not None and "light" in settings:
        out["light"] = _light(bench, float(settings["light"]), cap_s, cancel)
    mono = getattr(bench, "monochromator", None)
    if "wavelength" in kinds and mono is not None and "wavelength" in settings:
        out["wavelength"] = _wavelength(bench, mono, float(settings["wavelength"]), cap_s, cancel)
    return out


def _light(bench, level: float, cap_s: float, cancel) -> dict:
    light = bench.light
    read = getattr(light, "read_level", None)
    tol = getattr(light, "level_tolerance", None)
    got = read() if read is not None else None
    if got is None:
        return {"verified": False, "why": "settling not verified: the light source gives no reading of its output "
                                          "(no 'read' command in its <protocol>): the declared waits are trusted"}
    if tol is None:
        return {"verified": False, "read": float(got),
                "why": "settling not verified: the light source declares no tolerance (<light_source tolerance>) "
                       "to judge its reading by: the declared waits are trusted"}
    name = getattr(light, "name", "the light source")
    first = [got]  # (the reading just taken is the first poll's)
    return _poll(bench, lambda: first.pop() if first else read(), level, float(tol), cap_s, cancel, name, "light level",
                 getattr(getattr(light, "cfg", None), "unit", None) or "photons/pixel/s", "its monitor's reading",
                 '<after quantity="light" settle_s>')


def _wavelength(bench, mono, nm: float, cap_s: float, cancel) -> dict:
    if getattr(mono, "completion", False):
        return {"verified": True, "waited_s": 0.0,
                "why": "the monochromator answered its 'complete' command (operation complete) when the move was done"}
    bw = mono.bandwidth()
    tol = bw / 2 if math.isfinite(bw) and bw > 0 else WAVELENGTH_TOL_NM
    rec = _poll(bench, mono.get_wavelength, nm, tol, cap_s, cancel, getattr(mono, "name", "the monochromator"),
                "wavelength", "nm", "its position readback ('get')", '<after quantity="wavelength" settle_s>',
                steady=tol / 100)
    rec["why"] += ("; it declares no 'complete' command, so the grating's ringing after the drive stops is "
                   "not seen")
    return rec


def _poll(bench, read, want: float, tol: float, cap_s: float, cancel, name: str, what: str, unit: str,
          evidence: str, declared: str, steady: float | None = None) -> dict:
    """Read until within ``tol`` of ``want`` (with ``steady``: and within that of the reading before --
    a drive passing through its target on the way is not there), polling on the bench's clock."""
    clock = getattr(bench, "clock", None)
    now = clock.now if clock is not None else None
    sleep = clock.sleep if clock is not None else None
    t0 = now() if now is not None else None
    waited, dt, before = 0.0, FIRST_POLL_S, None
    while True:
        got = float(read())
        still = steady is None or (before is not None and abs(got - before) <= steady)
        before = got
        if abs(got - want) <= tol * (1 + 1e-9) and (still or steady is not None and waited == 0 and
                                                    abs(got - want) <= steady):
            why = (f"at its set point by {evidence} ({got:.6g} {unit}, within +/- {tol:.3g})" if waited == 0 else
                   f"not at its set point when the declared waits were over (slower than declared); waited "
                   f"{waited:.3g} s more until {evidence} was within +/- {tol:.3g} {unit} of {want:.6g}")
            return {"verified": True, "waited_s": waited, "read": got, "tolerance": tol, "why": why}
        if waited >= cap_s:
            raise HardwareError(
                f"{name}: {what} not settled {waited:.3g} s after the declared settle time ({evidence} {got:.6g} {unit}, "
                f"set {want:.6g} +/- {tol:.3g}; the cap is <settle max_s=\"{cap_s:g}\">): it settles slower than "
                f"declared ({declared})")
        step = min(dt, cap_s - waited)
        wait(step, cancel, **({"sleep": sleep, "clock": now} if clock is not None else {}))
        waited = (now() - t0) if now is not None else waited + step
        dt = min(2 * dt, MAX_POLL_S)
