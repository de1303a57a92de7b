"""The frame in flight at a register, light or temperature change (``ares.scan.apply``; FORMAT.md, Bench dynamics).

A streaming sensor is already exposing the next frame when the host writes a stage's
registers, and a grabber may hold frames exposed before (at its last stop): the first frame
delivered after the change started its exposure -- wholly or partly -- with the old settings.
Where the settle keeps the frames that follow a change (``<settle by="time">`` or a dark whose
frames after the change are its measurement), the host looks at the first frame and asks the
device what it is:

- its exposure start (the device's time stamp -- the ``ares40`` header, GenTL's, the simulator's
  frame stamp -- on the bench's clock, which the emulated and simulated devices run on): a frame
  that started before the commit is discarded, the first that started after it is kept (the
  stack's first frame: nothing fresh is wasted);
- its tags (the exposure/gain a device tags its frames with): a frame tagged with other settings
  than the registers now hold is discarded; tags that match are proof when they cover every
  changed register;
- nothing (a real grabber's ``ares32`` header: a counter, no time): the host cannot tell the frames
  in flight from fresh ones, so it discards as many frames as the device can hold in flight -- the
  pipeline depth the system declares (``<timing frames_in_flight="N">``), else one (assumed) -- and
  the record says so.

The same holds at a light, temperature or wavelength change (a monochromator's: the light on the
sensor, its QE there): a grabber still holds frames exposed under the
old light (its FIFO) and one was exposing when it changed. The time compared with is when the change
was complete -- the instrument settled (a monochromator's move: its ``*OPC?``), the declared waits over
and the source found there by its own evidence (``ares.scan.source_settled``) -- and no tag tells the light, so
only a time stamp proves a frame fresh; without one, the pipeline depth's frames are discarded.

A declared ``discard_frames`` >= 1 is trusted to take the frame in flight (nothing is looked at).

The record (the stage JSON's ``settling`` -> ``in_flight``): ``discarded``, ``kept`` (1: the frame
looked at was fresh and is the stack's first), ``evidence`` ("device timestamp", "frame tags",
"none"), ``why``; when nothing told (``evidence`` "none"): ``frames_in_flight`` (the frames discarded
blind) and ``depth`` ("declared": ``<timing frames_in_flight>``; "assumed": one, none declared). Where
the device's evidence shows more stale frames than the declared depth, ``depth_exceeded``
({"declared", "seen"}) and a warning: the declaration is checked wherever the device can check it."""

from __future__ import annotations

import logging

import numpy as np

from ares.protocol.system import IN_FLIGHT_CAP
from ares.scan.settling import _grab1, tags_match

log = logging.getLogger(__name__)
CAP = IN_FLIGHT_CAP  # frames exposed before a change that a device may still deliver (a grabber's FIFO)


def exposure_start(bench, frame) -> float | None:
    """When ``frame`` started exposing, on the bench's clock; None when nothing tells. The devices
    of a bench with a clock (the simulator, the emulators behind the wires) run on it: their time
    stamps compare with the commit; a real device's clock is not the host's."""
    clock = getattr(bench, "clock", None)
    if clock is None:
        return None
    dev = (frame.meta or {}).get("device_timestamp_s")
    if dev is not None:
        return float(dev)
    if getattr(bench.frames, "clock", None) is clock:  # the simulator stamps each frame at its exposure start
        return float(frame.timestamp)
    return None


def judge(bench, frame, committed: float | None, want: dict, tags_cover: bool) -> tuple[bool | None, str]:
    """(fresh: True, exposed before the change: False, cannot tell: None; the evidence)."""
    tagged = any(k in (frame.meta or {}) for k in ("exposure_s", "analog_gain"))
    if tagged and tags_match(frame.meta, want) is False:
        return False, "frame tags"
    start = exposure_start(bench, frame) if committed is not None else None
    if start is not None:
        return start >= committed - 1e-9, "device timestamp"  # (1 ns: a time stamp's resolution)
    if tagged and tags_cover:
        return True, "frame tags"
    return None, "none"


def drop_in_flight(bench, want: dict, tags_cover: bool, committed: float | None, what: str = "register change",
                   depth: int | None = None) -> dict:
    """After a register change committed at ``committed`` (the bench's clock; None: a bench without
    one), no frame discarded by declaration: discard what the device says was exposed before it, or
    the first frame when it says nothing; the first fresh frame goes back to the frame source
    (``push_back``). ``want``: the tags a fresh frame carries (``exposure_s``/``analog_gain`` as the
    registers hold them); ``tags_cover``: they cover every register changed (never a light change's: no
    tag tells the light). ``what``: the change, as the record names it ("light change")."""
    dropped, evidence = 0, "none"
    while dropped < CAP:
        frame = _grab1(bench)
        fresh, evidence = judge(bench, frame, committed, want, tags_cover)
        if fresh is False:
            dropped += 1
            continue
        if fresh is None and not dropped:
            n = min(max(int(depth or 1), 1), CAP)
            for _ in range(n - 1):  # the rest of the pipeline: no more evidence than the first
                _grab1(bench)
            told = (f"the pipeline depth the system declares (<timing frames_in_flight=\"{n}\">)" if depth is not None
                    else "one assumed: the system declares no pipeline depth (<timing frames_in_flight>)")
            return {"discarded": n, "kept": 0, "evidence": "none", "frames_in_flight": n,
                    "depth": "declared" if depth is not None else "assumed",
                    "why": f"{n} frame(s) discarded, as many as may be in flight at the {what} ({told}): they may "
                           "have been exposed partly before the change was complete, and the device gives neither its "
                           "exposure start nor its settings to tell"}
        if (evidence == "device timestamp" and "register" in what and depth is not None
                and dropped < depth):
            # a time stamp tells when a frame started, not which settings it latched: a sensor whose
            # registers take effect frames late (double-buffered) delivers frames started after the
            # write with the old settings -- the declared depth's frames go unless tags prove them
            late = int(depth) - dropped
            for _ in range(late - 1):
                _grab1(bench)
            return {"discarded": dropped + late, "kept": 0, "evidence": evidence, "frames_in_flight": int(depth),
                    "depth": "declared",
                    "why": f"{dropped} frame(s) exposed before the {what} was complete discarded ({evidence}), and "
                           f"{late} more up to the pipeline depth the system declares (<timing frames_in_flight="
                           f"\"{depth}\">): a time stamp tells when a frame started, not which settings it latched "
                           "(a sensor whose registers take effect frames late), and no tag tells"}
        push_back(bench.frames, [frame])  # fresh: the stack's first frame
        if dropped:
            why = (f"{dropped} frame(s) exposed before the {what} was complete discarded ({evidence}); "
                   "the first after it is kept")
        else:
            why = f"no frame was exposed before the {what} was complete ({evidence}): the first after it is kept"
        rec = {"discarded": dropped, "kept": 1, "evidence": evidence, "why": why}
        if depth is not None and dropped > depth:  # the device's evidence against the system's declaration
            rec["depth_exceeded"] = {"declared": int(depth), "seen": dropped}
            rec["why"] += (f"; the device held {dropped} frames exposed before the change, more than the pipeline "
                           f"depth the system declares (<timing frames_in_flight=\"{depth}\">): where it tells "
                           f"nothing (no time stamp, no tags) {dropped - depth} stale frame(s) would be kept -- "
                           f"declare frames_in_flight=\"{dropped}\"")
            log.warning("%s", rec["why"])
        return rec
    return {"discarded": dropped, "kept": 0, "evidence": evidence,
            "why": f"{dropped} frames in a row were exposed before the {what} was complete ({evidence}); the stack "
                   "follows regardless"}


def push_back(src, frames: list) -> None:
    """The frame source's next grab yields ``frames`` first, then its own (once: the source is
    itself again after that grab). A frame looked at to judge the change is not lost."""
    ahead = list(frames)
    own = src.__dict__.get("grab")

    def grab(n):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n <= 0:
            return (own or type(src).grab.__get__(src))(n)
        if own is None:
            src.__dict__.pop("grab", None)
        else:
            src.grab = own
        take, rest = ahead[:n], ahead[n:]
        if rest:
            push_back(src, rest)
            return iter(take)
        return _then(take, src.grab(n - len(take)) if n > len(take) else None)

    src.grab = grab


def _then(first: list, rest):
    yield from first
    if rest is not None:
        yield from rest  # (closed with this generator: a source's grab finishes as it would)
