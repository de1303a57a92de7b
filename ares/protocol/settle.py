"""``<timing><settle .../></timing>``: how the runner decides a bench has settled after a change
(``ares.scan.settling``): by what the frames say (``by="frames"``, the default) or by the
declared waits alone (``by="time"``).

By the frames: frames are grabbed ``probe_s`` apart, each gap ``growth`` times the one before
(on the bench's clock), after the declared
minimum wait and discards (``settle_s``, ``discard_frames``, ``<after>``) until ``agree``
consecutive pairs agree -- frames tagged with their exposure/gain (a device's chunk data)
must carry the new settings, and consecutive frame means must agree within ``k`` standard
errors of their temporal noise or within ``rtol`` of the level, whichever is wider -- or until
``max_s`` seconds / ``max_frames`` frames (the cap: the stage is then named unsettled). Each
stack is checked afterwards for a trend or a step by the same criterion; under ``<suspend>``
a stack that fails it is acquired again, up to ``reacquire`` times."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ares.protocol.xmlsafe import fail


@dataclass(frozen=True)
class Settle:
    by: str = "frames"  # "frames": by the evidence of the frames; "time": the declared waits only
    k: float = 4.0  # agreement: |difference of frame means| <= max(k * its standard error, rtol * level)
    rtol: float = 0.001
    probe_s: float = 0.2  # bench time between the first probe frames
    growth: float = 1.5  # each gap this many times the one before (a slow drift shows its whole remaining change)
    agree: int = 2  # consecutive agreeing pairs that prove the bench settled
    max_s: float = 30.0  # cap on the wait (bench time), beyond the declared minimum
    max_frames: int = 60  # cap on the probe frames
    reacquire: int = 2  # under <suspend>: a stack that trends or steps is acquired again this often


def settle_from_el(path, el) -> Settle:
    if el is None:
        return Settle()
    d = Settle()
    try:
        s = Settle(el.get("by", d.by), float(el.get("k", d.k)), float(el.get("rtol", d.rtol)),
                   float(el.get("probe_s", d.probe_s)), float(el.get("growth", d.growth)), int(el.get("agree", d.agree)),
                   float(el.get("max_s", d.max_s)), int(el.get("max_frames", d.max_frames)),
                   int(el.get("reacquire", d.reacquire)))
    except ValueError as exc:
        raise fail(path, el.sourceline, f"<settle>: {exc}") from None
    if s.by not in ("frames", "time"):
        raise fail(path, el.sourceline, f"<settle by='{s.by}'> must be 'frames' or 'time'")
    for name in ("k", "rtol", "probe_s", "max_s"):
        v = getattr(s, name)
        if not (math.isfinite(v) and v >= 0):
            raise fail(path, el.sourceline, f"<settle {name}='{v}'> must be a finite number >= 0")
    if s.growth < 1:
        raise fail(path, el.sourceline, f"<settle growth='{s.growth}'> must be >= 1")
    if s.agree < 1 or s.max_frames < s.agree + 1 or s.reacquire < 0:
        raise fail(path, el.sourceline, "<settle> needs agree >= 1, max_frames >= agree + 1 and reacquire >= 0")
    return s


def settle_to_el(parent, s: Settle, sub) -> None:
    """``<settle>`` under ``parent`` with the attributes that differ from the defaults."""
    d = Settle()
    diff = {k: getattr(s, k) for k in d.__dataclass_fields__ if getattr(s, k) != getattr(d, k)}
    if diff:
        el = sub(parent, "settle")
        for k, v in diff.items():
            el.set(k, str(v) if not isinstance(v, float) else repr(v))
