"""Link statistics and device identities for the run record (issue 36, finding 9).

Every bench part that talks over a link counts what happened on it since it was opened
(``link_counters()``: the USB grabber's bulk transfers, bytes, short packets, zero-length
packets, timeouts, overflows, resyncs and lost frames; the I2C bus's transactions and its
retries after a NACK, a busy bus or a timeout; a serial instrument's commands, retries,
garbled replies and timeouts; a GenICam camera's frames, drops and timeouts) and says what it
is (``identity()``: USB VID:PID and serial number, I2C bus/address and the chip ID read at
connect, the serial instrument's answer to its identify command, the GenICam camera's
vendor/model/serial). The runner records per stage the counts that stage caused
(stages/NNNN.json ``link``, and ``link_<part>_<counter>`` scalars in stages/NNNN.h5) and in
run.json the totals since the bench opened (``link``) and the identities (``devices``).

Duck-typed: a part without the methods (the simulator, a replay) is left out. No I/O here.
"""

from __future__ import annotations

PARTS = ("frames", "registers", "light", "chamber")

def _parts(bench) -> dict:
    return {"frames": bench.frames, "registers": getattr(bench.registers, "bus", None), "light": bench.light,
            "chamber": bench.chamber}


def counters(bench) -> dict:
    """``{part: {counter: count}}`` of every bench part that counts, now."""
    out = {}
    for part, dev in _parts(bench).items():
        fn = getattr(dev, "link_counters", None)
        if callable(fn):
            out[part] = {k: int(v) for k, v in fn().items()}
    return out


ROUTINE = ("commands", "transfers", "bytes", "short_packets", "zlps", "transactions", "frames")


def trouble(counts: dict) -> dict:
    """The counters of ``counts`` that tell of trouble (not the routine traffic) and are not 0."""
    out = {}
    for part, c in counts.items():
        bad = {k: v for k, v in c.items() if k not in ROUTINE and v}
        if bad:
            out[part] = bad
    return out


def trouble_text(counts: dict) -> str:
    """``frames 1 timeouts, 1 stalls; light 3 ignored lines`` (``trouble``'s counts)."""
    return "; ".join(f"{part} " + ", ".join(f"{v} {_WORDS.get(k, k.replace('_', ' '))}" for k, v in c.items())
                     for part, c in counts.items())


def delta(before: dict, after: dict) -> dict:
    """What happened between two ``counters`` readings (same parts, same counters)."""
    return {part: {k: v - before.get(part, {}).get(k, 0) for k, v in c.items()} for part, c in after.items()}


def identities(bench) -> dict:
    """``{part: identity}`` of every bench part that can say what it is."""
    out = {}
    for part, dev in _parts(bench).items():
        fn = getattr(dev, "identity", None)
        if callable(fn):
            ident = fn()
            if ident:
                cfg = getattr(dev, "cfg", None)  # the XML's name for it ('grabber', 'led'), else the device's
                out[part] = dict(ident, name=str(getattr(cfg, "name", None) or getattr(dev, "name", part)))
    return out


def arrays(link: dict | None) -> dict:
    """A stage's counts as HDF5 scalars ``link_<part>_<counter>`` (int64)."""
    import numpy as np

    return {f"link_{part}_{k}": np.int64(v) for part, c in (link or {}).items() for k, v in c.items()}


# ------------------------------------------------------------ text (terminal and report)

_WORDS = {"zlps": "ZLPs", "nack_retries": "NACK retries", "busy_retries": "bus-busy retries"}


def _counts(c: dict) -> str:
    """The counts that are not 0, then "(others 0)" when some were."""
    text = ", ".join(f"{v} {_WORDS.get(k, k.replace('_', ' '))}" for k, v in c.items() if v)
    return (text or "nothing") + (" (others 0)" if text and 0 in c.values() else "")


def device_lines(meta: dict) -> list[tuple[str, str]]:
    """(label, text) per device of run.json's ``devices``: what each bench part said it is."""
    out = []
    for part in PARTS:
        d = (meta.get("devices") or {}).get(part)
        if not isinstance(d, dict):
            continue
        rest = {k: v for k, v in d.items() if k not in ("name", "interface")}
        text = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in rest.items())
        out.append((part, f"{d.get('name', part)} ({d.get('interface', '?')}){': ' + text if text else ''}"))
    return out


def link_lines(meta: dict) -> list[tuple[str, str]]:
    """(label, text) per bench part of run.json's ``link`` totals."""
    link = meta.get("link") or {}
    return [(f"{part} link", _counts(link[part])) for part in PARTS if isinstance(link.get(part), dict)]
