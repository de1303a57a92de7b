"""Apply a stage's resolved settings to a bench (slow instruments first, light last; the register
fields as one change, inside one group hold where the register map declares one), then
let the bench settle as the system XML declares (``<timing>``): wait ``settle_s`` and drop
``discard_frames`` frames after a change (frames still exposed at the old settings), drain
the frame source (``flush``), and tell it the frame time its read timeouts must cover. The
frame in flight at a register, light or temperature change is never kept (``ares.scan.in_flight``);
under ``<settle by="time">`` a light source or monochromator is checked to be settled after the declared
waits where the rig gives evidence (``ares.scan.source_settled``)."""

from __future__ import annotations

from ares.errors import InputError
from ares.hardware.waits import wait

TAGS = {"exposure": "exposure_s", "analog_gain": "analog_gain"}  # a control -> the tag of a frame exposed with it


def apply_settings(bench, system, settings: dict, previous: dict | None = None, cancel=None,
                   evidence: bool = True, noise=None, abort=None) -> dict | None:
    """Write every setting; instruments only settle when their value changed. ``cancel``:
    a callable that is true when the run is asked to stop; an instrument's wait then ends
    with ``ares.hardware.waits.Interrupted``. Returns what the bench waited and discarded
    and why (``settle``); ``evidence=False``: the declared waits only (a dark whose decay
    of image lag is the measurement). ``abort``: what ends the probe frames' waits (a stop
    lets the stage in flight finish, its settling included, within the cap); default ``cancel``."""
    prev = previous or {}
    kinds = set()  # what changed: "registers", "light", "temperature"
    regs, changed_regs = {}, []  # the register fields: written together, as one change, after the
    for key, value in settings.items():  # chamber and before the monochromator and the light
        if (name := register_field(system, key)) is not None:
            regs[name] = value
            if prev.get(key) != value:
                changed_regs.append(name)
                kinds.add("registers")
    writes, written = None, not regs
    committed = None  # the bench's clock when the register change was committed (the frame in flight)
    clock = getattr(bench, "clock", None)
    for key, value in settings.items():
        if register_field(system, key) is not None:
            continue
        changed = prev.get(key) != value
        if changed:
            kinds.add(key)
        if key in ("light", "wavelength") and not written:
            writes, written = write_registers(bench, regs, changed_regs), True
            committed = clock.now() if clock is not None else None
        if key == "temperature":
            if bench.chamber is None:
                raise InputError(f"system '{system.name}' has no thermal chamber to set {value:g} C")
            if changed:
                bench.chamber.set_temperature(value)
                bench.chamber.settle(cancel)
        elif key == "light":
            if bench.light is None:
                if value == 0:
                    continue
                raise InputError(f"system '{system.name}' has no light source to set level {value:g}")
            if changed:
                bench.light.set_level(value)
                bench.light.settle(cancel)
        elif key == "wavelength":
            if getattr(bench, "monochromator", None) is None:
                raise InputError(f"system '{system.name}' has no monochromator to set {value:g} nm")
            if changed:
                bench.monochromator.set_wavelength(value)
                if getattr(bench, "photodiode", None) is not None:  # a power meter corrects for it
                    bench.photodiode.set_wavelength(value)
                bench.monochromator.settle(cancel)
        else:  # the protocol layer admits no other key
            raise InputError(f"unknown setting '{key}'")
    if not written:
        writes = write_registers(bench, regs, changed_regs)
        committed = clock.now() if clock is not None else None
    rec = settle(bench, system, settings, kinds, cancel, evidence, noise, abort,
                 (changed_regs, committed) if changed_regs else None)
    if rec is not None and writes is not None and changed_regs:
        rec["registers"] = writes  # whether the change took effect at one frame start, and how
    return rec


def write_registers(bench, values: dict, changed) -> dict | None:
    """A stage's register fields as one change (``RegisterFile.set_many``: inside one group hold
    where the register map declares one); what was done, for the stage's record."""
    many = getattr(bench.registers, "set_many", None)
    if many is not None:
        return many(values, changed)
    for name, value in values.items():  # a register file of another kind: one at a time
        bench.registers.set(name, value)
    return None


def settle(bench, system, settings: dict, kinds: set, cancel=None, evidence: bool = True,
           noise=None, abort=None, registers: tuple | None = None) -> dict | None:
    """After the changes ``kinds``: the longest declared settle time (on the bench's clock),
    the most frames to discard (``Timing.after_change``), a flush when declared; then, with
    ``<settle by="frames">`` (the default), probe frames until they prove the bench settled
    (``ares.scan.settling``). The frame time (exposure + readout) goes to the frame source's
    read timeouts. ``registers``: (the register fields changed, when on the bench's clock): where the
    frames after the change are kept as they come (``by="time"``, or ``evidence=False``), the frame in
    flight at the change is never among them (``ares.scan.in_flight``) -- at a light, temperature or
    wavelength change, no frame that started before the instrument settled and the declared waits were over.
    Returns the record of what was waited and discarded and why (None: no change)."""
    t = getattr(system, "timing", None)
    if t is None:
        return None
    frame_time = getattr(bench.frames, "set_frame_time", None)
    if frame_time is not None and "exposure" in settings:
        frame_time(float(settings["exposure"]) + t.readout_s + t.margin_s)
    waits = [t.after_change(k) for k in kinds]
    seconds = max((w[0] for w in waits), default=0.0)
    discard = max((w[1] for w in waits), default=0)
    depth = getattr(t, "frames_in_flight", None)
    raised = bool(discard) and depth is not None and discard < depth  # a declared discard below the declared depth
    if raised:  # would keep a frame the pipeline still held: the depth wins, the record says so
        discard = depth
    clock = getattr(bench, "clock", None)
    if seconds > 0:
        if clock is not None:
            wait(seconds, cancel, sleep=clock.sleep, clock=clock.now)
        else:
            wait(seconds, cancel)
    cfg = t.settle
    replay = getattr(bench.frames, "recorded", False)  # a replay: its frames are the recording's, nothing settles
    sources = None
    if (cfg.by != "frames" or not evidence) and not replay and kinds & {"light", "wavelength"}:
        from ares.scan.source_settled import check_sources  # is the source there? (else wait for it, or fail)

        sources = check_sources(bench, settings, kinds, cfg.max_s, cancel)
    done = clock.now() if clock is not None else None  # an instrument's change is complete (its settle, the waits)
    if discard:
        for _ in bench.frames.grab(discard):
            pass
    if t.flush:
        flush = getattr(bench.frames, "flush", None)
        if flush is not None:
            flush()
    if not kinds:
        return None
    rec = {"changed": sorted(kinds), "declared_wait_s": seconds, "discarded": discard}
    if raised:
        rec["why_discarded"] = (f"{discard} frames, the declared pipeline depth (<timing frames_in_flight=\"{depth}\">): "
                                "the declared discard_frames is fewer, and would keep a frame still in flight")
    if replay:
        rec.update(by="time", settled=None, why="recorded frames: nothing to settle")
        return rec
    if cfg.by != "frames" or not evidence:
        rec.update(by="time", settled=None, why="the declared waits only" if evidence else
                   "the declared waits only: the frames after this change are the measurement")
        if sources:  # the sources' own evidence after the declared waits (ares.scan.source_settled)
            rec["sources"] = sources
            rec["why"] += ", then the sources' own evidence ('sources')"
        slow = sorted(kinds & {"light", "temperature", "wavelength"})  # instruments: complete when settled and waited for
        if (registers is not None or slow) and not discard:  # the frame in flight at the change is not kept
            from ares.scan.in_flight import drop_in_flight

            changed, committed = registers if registers is not None else ((), None)
            if slow:  # no frame that started before the light (the chamber) reached its new level
                committed = done
            want = {tag: bench.registers.get(register_field(system, key)) for key, tag in TAGS.items()
                    if key in settings and register_field(system, key) is not None}
            cover = not slow and set(changed) <= {register_field(system, k) for k in TAGS if k in settings}
            what = " and ".join(slow + (["register"] if registers is not None else [])) + " change"
            rec["in_flight"] = drop_in_flight(bench, want, bool(want) and cover, committed, what,
                                              getattr(t, "frames_in_flight", None))
            rec["discarded"] = rec["in_flight"]["discarded"]
        return rec
    def want() -> dict:  # the settings as the registers hold them (read only when the frames carry tags)
        out = {}
        for key, tag in TAGS.items():
            name = register_field(system, key)
            if key in settings and name is not None:
                out[tag] = bench.registers.get(name)
        return out

    from ares.scan.settling import settle_by_frames

    rec.update(settle_by_frames(bench, cfg, want, abort if abort is not None else cancel, noise=noise))
    return rec


def as_fields(system, settings: dict) -> dict:
    """A stage's settings as the bench's frame source names them: register field ->
    physical value (``exposure`` and ``analog_gain`` by the system's control fields),
    ``light``, ``temperature`` and ``wavelength`` as they are."""
    return {register_field(system, key) or key: value for key, value in settings.items()}


def register_field(system, key: str) -> str | None:
    """The register field a setting writes (``exposure``/``analog_gain``: the system's
    control fields; ``reg:NAME``: NAME), None for an instrument's (light, temperature, wavelength)."""
    if key in ("exposure", "analog_gain"):
        return getattr(system.controls, key)
    return key[4:] if key.startswith("reg:") else None
