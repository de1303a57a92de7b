"""The dark current's verdict where the offset's drift on the bench's clock could not be separated from
it (``ares.analysis.ptc.dark_drift``): each frame's readout time from a stage's ``bench_position``, the
rate's JSON marked "drift not separated" with why and what to do, and the doubling temperature fitted
through such a rate marked so too. Imports nothing of ARES (a run's arrays through its ``arrays``)."""

from __future__ import annotations

import math


def frame_times(stage: dict, run=None) -> list | None:
    """Each frame's readout time (s) of a stage's stack, on one clock for the whole run:

    * the simulator's: from the stage's ``bench_position`` -- the stack's frames fill [its start,
      the stage's end] evenly, each read out at the end of its slot (the simulator's clock advances
      by each frame's exposure; its time stamp is the exposure's start);
    * a real bench's (``run`` given, its results.h5): the device's time stamps (exposure start:
      ares40 header, GenICam) + the exposure, else the host's arrival times (the frame read out).

    None where the stage has neither."""
    n = len(stage["views"]["full"]["level"].get("frame_means") or [])
    pos = stage.get("bench_position") or {}
    a, b = (pos.get("flat") or {}).get("clock_s"), (pos.get("end") or {}).get("clock_s")
    if a is not None and b is not None and n >= 1 and b > a:
        return [a + (i + 1) * (b - a) / n for i in range(n)]
    arrays = getattr(run, "arrays", None)
    if arrays is None or n < 2:
        return None
    try:
        got = arrays(stage["index"], names=("frame_device_timestamp", "frame_timestamp"))
    except OSError:  # results.h5 unreadable: no times (the rate as without them), never a failed analysis
        return None
    exposure = stage["settings"].get("exposure")
    dev, host = got.get("frame_device_timestamp"), got.get("frame_timestamp")
    if dev is not None and len(dev) == n and exposure is not None and all(map(math.isfinite, dev)):
        return [float(t) + float(exposure) for t in dev]
    if host is not None and len(host) == n:
        return [float(t) for t in host]
    return None


DRIFT_VERDICT = "drift not separated"


def drift_verdict(d: dict, drift) -> dict:
    """A rate the order of the exposures could not separate from the offset's drift: not "ok",
    with why and what to do (``ares.analysis.ptc.dark_drift``)."""
    if drift is not None and not drift.separable and d.get("verdict") == "ok":
        d.update(verdict=DRIFT_VERDICT, drift=drift.why, note=f"{DRIFT_VERDICT}: {drift.why}; {d.get('note', '')}")
    return d


def inherit(out: dict, rows) -> dict:
    """The temperature analysis's figures (``out``) fitted through the rates ``rows`` [(temperature C,
    rate JSON)]: not "ok" where one of those rates is "drift not separated"."""
    hit = [f"{t:g} C" for t, r in rows if r.get("verdict") == DRIFT_VERDICT]
    for key in ("doubling_temperature_c", "rate_at_ref_dn_per_s", "rate_at_ref_e_per_s") if hit else ():
        if out[key].get("verdict") == "ok":  # a rate the drift confounds is in the fit: neither is "ok"
            out[key].update(verdict=DRIFT_VERDICT, drift=f"the dark current at {', '.join(hit)}: drift not separated "
                                                          "from it (see dark_current)")
    return out
