"""The dark current's verdict where the offset's drift on the bench's clock could not be separated from
it (``ares.analysis.ptc.dark_drift``): each frame's readout time from a stage's ``bench_position``, the
rate's JSON marked "drift not separated" with why and what to do, and the doubling temperature fitted
through such a rate marked so too. Imports nothing of ARES."""

from __future__ import annotations


def frame_times(stage: dict) -> list | None:
    """Each frame's readout time (s on the bench's clock) of a stage's stack, from its
    ``bench_position``: the stack's frames fill [its start, the stage's end] evenly, each read out
    at the end of its slot (the simulator's clock advances by each frame's exposure; a frame's
    time stamp is its exposure's start). None where the stage has no clock position."""
    pos = stage.get("bench_position") or {}
    a, b = (pos.get("flat") or {}).get("clock_s"), (pos.get("end") or {}).get("clock_s")
    n = len(stage["views"]["full"]["level"].get("frame_means") or [])
    if a is None or b is None or n < 1 or not b > a:
        return None
    return [a + (i + 1) * (b - a) / n for i in range(n)]


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
