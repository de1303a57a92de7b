"""The devices of a system XML (``<buses>``, ``<devices>``): I2C bus, USB grabber, serial
instruments with their line protocol, GenICam camera -- dataclasses, loading and saving.

``ares.protocol.system`` composes these into a ``System``; the hardware layer
(``ares.hardware``) reads them. Nothing here opens a device.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lxml import etree

from ares.hardware.line_protocol import LineProtocol
from ares.hardware.pixels import WIRE_ORDERS, pixel_format
from ares.hardware.trigger import Trigger
from ares.protocol.line_xml import protocol_from_el, protocol_to_el
from ares.protocol.xmlsafe import fail


def _int(s, default=None):
    if s is None:
        return default
    s = s.strip()
    return int(s, 16) if s.lower().startswith("0x") else int(s)


def _float(s, default=None):
    return default if s is None else float(s)


def _bool(s, default=False):
    return default if s is None else s.strip() in ("true", "1")


def fmt(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _set(el, **attrs):
    for k, v in attrs.items():
        if v is not None:
            el.set(k, fmt(v))
    return el


# ---------------------------------------------------------------- I2C

@dataclass(frozen=True)
class I2CBus:
    """``<i2c name bus address speed_hz retries verify value_endian readback ...>``.

    ``retries``: further attempts after a NACK/timeout before the error; ``verify``: read
    every written register back; ``value_endian``: byte order of a multi-byte register
    value on the wire. ``readback="image_row"``: the sensor cannot be read over I2C; it
    writes its registers into image row ``readback_row`` when ``readback_field`` is 1, one
    byte per pixel from register ``readback_start`` (``ares.hardware.i2c.ImageRowReadback``).
    """

    name: str
    bus: int
    address: int
    speed_hz: int = 400000
    retries: int = 2
    verify: bool = False
    value_endian: str = "big"
    readback: str = "i2c"
    readback_row: int = 0
    readback_start: int = 0
    readback_field: str | None = None
    chip_id: tuple[int, int] | None = None  # (register, expected value): checked at connect
    init: tuple[tuple[str, float, int], ...] = ()  # ("write", register, value) / ("wait", seconds, 0), at connect
    backoff_ms: float = 1.0  # the busy window: the first pause before a retry (doubled each attempt)


def i2c_from_el(path, el) -> I2CBus:
    b = I2CBus(el.get("name"), int(el.get("bus")), _int(el.get("address")), _int(el.get("speed_hz"), 400000),
               _int(el.get("retries"), 2), _bool(el.get("verify")), el.get("value_endian", "big"),
               el.get("readback", "i2c"), _int(el.get("readback_row"), 0), _int(el.get("readback_start"), 0),
               el.get("readback_field"), _chip_id(el.find("chip_id")),
               tuple(("write", _int(s.get("register")), _int(s.get("value"))) if s.tag == "write"
                     else ("wait", float(s.get("ms")) / 1000.0, 0)
                     for s in el.iterfind("init/*") if isinstance(s.tag, str)),
               _float(el.get("backoff_ms"), 1.0))
    if b.address > 0x7F:
        raise fail(path, el.sourceline, f"I2C bus '{b.name}': address 0x{b.address:x} is not a 7-bit address")
    return b


def group_hold_from_el(reg_el) -> tuple[int, int, int] | None:
    """``<registers><group_hold register hold release>``: (register, hold value, release value)."""
    el = reg_el.find("group_hold")
    return None if el is None else (_int(el.get("register")), _int(el.get("hold")), _int(el.get("release")))


def check_buses(path, root, buses: tuple, regmap) -> None:
    """Several I2C devices: names unique; ``<registers bus>`` and every ``<field bus>`` name one;
    a ``buffered="shadow"`` field gives its ``shadow`` address (inside the address space)."""
    names = [b.name for b in buses]
    line = root.find("buses").sourceline if root.find("buses") is not None else root.sourceline
    if len(set(names)) != len(names):
        raise fail(path, line, f"<buses> declares an <i2c name> twice ({', '.join(names)})")
    reg = root.find("registers")
    if regmap.bus is not None and regmap.bus not in names:
        raise fail(path, reg.sourceline, f"<registers bus='{regmap.bus}'> names no <i2c> (declared: "
                                         f"{', '.join(names) or 'none'})")
    els = {el.get("name"): el for el in (reg.iterfind("field") if reg is not None else ())}
    for f in regmap.fields:
        where = els[f.name].sourceline if f.name in els else line
        if f.bus is not None and f.bus not in names:
            raise fail(path, where, f"register field '{f.name}': bus='{f.bus}' names no <i2c> (declared: "
                                    f"{', '.join(names) or 'none'})")
        if f.buffered == "shadow" and f.shadow is None:
            raise fail(path, where, f"register field '{f.name}': buffered='shadow' needs shadow= (the address its "
                                    "pending value reads back at)")
        if f.shadow is not None and f.shadow + f.count > (1 << regmap.address_bits):
            raise fail(path, where, f"register field '{f.name}': shadow address 0x{f.shadow:x} is outside the "
                                    f"{regmap.address_bits}-bit address space")


def _chip_id(el):
    return None if el is None else (_int(el.get("register")), _int(el.get("value")))


def i2c_to_el(parent, b: I2CBus):
    d = I2CBus(b.name, b.bus, b.address)
    kw = {k: getattr(b, k) for k in ("retries", "verify", "value_endian", "readback", "readback_row",
                                      "readback_start", "readback_field", "backoff_ms") if getattr(b, k) != getattr(d, k)}
    el = _set(etree.SubElement(parent, "i2c"), name=b.name, bus=b.bus, address=f"0x{b.address:02X}",
              speed_hz=b.speed_hz, **kw)
    if b.chip_id is not None:
        _set(etree.SubElement(el, "chip_id"), register=f"0x{b.chip_id[0]:04X}", value=f"0x{b.chip_id[1]:X}")
    if b.init:
        init = etree.SubElement(el, "init")
        for kind, a, v in b.init:
            if kind == "write":
                _set(etree.SubElement(init, "write"), register=f"0x{a:04X}", value=f"0x{v:X}")
            else:
                _set(etree.SubElement(init, "wait"), ms=1000.0 * a)


# ---------------------------------------------------------------- USB grabber

@dataclass(frozen=True)
class UsbControl:
    """``<control when="open|start|stop" request_type request value index data>``: a control
    transfer the grabber needs; ``value="frames"`` sends the number of frames to grab."""

    when: str
    request_type: int
    request: int
    value: int | str = 0
    index: int = 0
    data: bytes = b""


def trigger_from_el(path, el) -> Trigger | None:
    if el is None:
        return None
    return Trigger(el.get("mode", "free_run"), _int(el.get("line"), 0), el.get("edge", "rising"),
                   _int(el.get("timeout_ms")), el.get("strobe", "off"), _int(el.get("strobe_line"), 1))


def check_simulated_trigger(path, root, wire: bool) -> None:
    """A ``<trigger>`` (a mode other than free run, or a strobe) on a system the simulator stands in
    for is refused, never silently ignored: the direct simulator computes each frame when it is
    grabbed and models neither; behind the wires only the emulated ``<usb_grabber>`` honours one."""
    for kind in ("usb_grabber", "genicam"):
        el = root.find(f"devices/{kind}/trigger")
        t = trigger_from_el(path, el)
        if t is None or (t.mode == "free_run" and t.strobe == "off") or (wire and kind == "usb_grabber"):
            continue
        what = f"<{kind}><trigger mode='{t.mode}' strobe='{t.strobe}'>"
        if wire:
            raise fail(path, el.sourceline, f"{what} is not emulated: behind the wires the simulator stands in for "
                                            "a <usb_grabber>, whose trigger it emulates; remove this <trigger>")
        raise fail(path, el.sourceline, f"{what} is not modelled by the direct simulator, which computes each frame "
                                        "when it is grabbed: run it behind the emulated grabber (<simulator "
                                        "wire=\"true\">) or remove the <trigger>")


def trigger_to_el(parent, t: Trigger | None):
    if t is not None:
        d = Trigger()
        _set(etree.SubElement(parent, "trigger"), **{k: getattr(t, k) for k in
                                                     ("mode", "line", "edge", "timeout_ms", "strobe", "strobe_line")
                                                     if getattr(t, k) != getattr(d, k)})


@dataclass(frozen=True)
class UsbGrabber:
    name: str
    vid: int
    pid: int
    endpoint: int
    format: str
    header_bytes: int = 0  # header="none": bytes to skip before the pixels (no counter, no checks)
    timeout_ms: int = 1000  # one bulk read
    serial: str | None = None  # iSerialNumber to pick one of several grabbers
    header: str = "none"  # "ares32": ares.hardware.frame_header
    chunk_bytes: int = 1 << 20  # bulk read size
    watchdog_ms: int | None = None  # a whole frame; default 4 x timeout_ms
    wire_order: str = "image"  # ares.hardware.pixels.WIRE_ORDERS
    interface: int = 0
    controls: tuple[UsbControl, ...] = ()
    counter: str | None = None  # "continuous", "per_grab", "free_running" (ares.hardware.usb.counter_mode)
    header_packet: str = "own"  # "own": the header is a short packet of its own; "inline": one transfer with the payload
    trigger: Trigger | None = None  # <trigger>: free run / software / hardware trigger, strobe
    timestamp_hz: float = 1e9  # header="ares40": the device clock's ticks per second


def _data(s: str | None) -> bytes:
    return bytes(int(x, 16) for x in s.split()) if s else b""


def usb_from_el(path, g) -> UsbGrabber:
    ctl = []
    for c in g.iterfind("control"):
        v = c.get("value", "0")
        ctl.append(UsbControl(c.get("when"), _int(c.get("request_type")), _int(c.get("request")),
                              v if v in ("frames", "mode", "strobe") else _int(v), _int(c.get("index"), 0),
                              _data(c.get("data"))))
    u = UsbGrabber(g.get("name"), _int(g.get("vid")), _int(g.get("pid")), _int(g.get("endpoint")), g.get("format"),
                   _int(g.get("header_bytes"), 0), _int(g.get("timeout_ms"), 1000), g.get("serial"),
                   g.get("header", "none"), _int(g.get("chunk_bytes"), 1 << 20), _int(g.get("watchdog_ms")),
                   g.get("wire_order", "image"), _int(g.get("interface"), 0), tuple(ctl), g.get("counter"),
                   g.get("header_packet", "own"), trigger_from_el(path, g.find("trigger")),
                   _float(g.get("timestamp_hz"), 1e9))
    if u.vid > 0xFFFF or u.pid > 0xFFFF:
        raise fail(path, g.sourceline, "USB vid/pid must be 16-bit numbers")
    pixel_format(u.format)  # the schema lists the names; this keeps one table
    if u.header != "none" and u.header_bytes:
        raise fail(path, g.sourceline, f"header='{u.header}' has its own header; drop header_bytes")
    t, whens = u.trigger, {c.when for c in u.controls}
    if t is not None:
        line = g.find("trigger").sourceline
        for need, why in (("trigger_mode", t.mode != "free_run"), ("trigger", t.mode == "software"),
                          ("strobe", t.strobe != "off")):
            if why and need not in whens:
                raise fail(path, line, f"<trigger mode='{t.mode}' strobe='{t.strobe}'> needs the grabber's "
                                       f"<control when='{need}'> (the request that does it on this device)")
    if u.wire_order not in WIRE_ORDERS:
        raise fail(path, g.sourceline, f"wire_order '{u.wire_order}' is not one of {', '.join(WIRE_ORDERS)}")
    return u


def usb_to_el(parent, g: UsbGrabber):
    el = _set(etree.SubElement(parent, "usb_grabber"), name=g.name, vid=f"0x{g.vid:04X}", pid=f"0x{g.pid:04X}",
              endpoint=f"0x{g.endpoint:02X}", format=g.format, header_bytes=g.header_bytes or None,
              timeout_ms=g.timeout_ms, serial=g.serial, header=None if g.header == "none" else g.header,
              chunk_bytes=None if g.chunk_bytes == 1 << 20 else g.chunk_bytes, watchdog_ms=g.watchdog_ms,
              wire_order=None if g.wire_order == "image" else g.wire_order, interface=g.interface or None,
              counter=g.counter, header_packet=None if g.header_packet == "own" else g.header_packet,
              timestamp_hz=None if g.timestamp_hz == 1e9 else g.timestamp_hz)
    for c in g.controls:
        _set(etree.SubElement(el, "control"), when=c.when, request_type=f"0x{c.request_type:02X}",
             request=f"0x{c.request:02X}", value=c.value, index=c.index,
             data=" ".join(f"{b:02X}" for b in c.data) or None)
    trigger_to_el(el, g.trigger)


# ---------------------------------------------------------------- serial instruments

NEEDS = {"light_source": ("set", "get"), "chamber": ("set", "get"), "monochromator": ("set", "get"),
         "photodiode": ("read",)}


@dataclass(frozen=True)
class SerialInstrument:
    name: str
    port: str
    baud: int = 9600
    bytesize: int = 8
    parity: str = "N"
    stopbits: int = 1
    timeout_s: float = 1.0
    min: float | None = None
    max: float | None = None
    unit: str | None = None
    settle_s: float = 0.0  # soak after the instrument reports settled
    settle_timeout_s: float = 3600.0  # chamber: give up waiting for the set point after this
    poll_s: float = 1.0  # chamber: poll interval while waiting
    tolerance: float | None = None  # chamber: settled = within +/- tolerance C of the set point ...
    hold_s: float = 0.0  # ... continuously for hold_s (without tolerance: the 'stable' command answers 1)
    protocol: LineProtocol | None = None  # None: DEFAULT_LIGHT / DEFAULT_CHAMBER


def serial_from_el(path, el, kind: str) -> SerialInstrument | None:
    if el is None:
        return None
    p = el.find("protocol")
    proto = None if p is None else protocol_from_el(path, p, kind, NEEDS[kind])
    return SerialInstrument(
        name=el.get("name"), port=el.get("port"), baud=_int(el.get("baud"), 9600), bytesize=_int(el.get("bytesize"), 8),
        parity=el.get("parity", "N"), stopbits=_int(el.get("stopbits"), 1), timeout_s=_float(el.get("timeout_s"), 1.0),
        min=_float(el.get("min")), max=_float(el.get("max")), unit=el.get("unit"), settle_s=_float(el.get("settle_s"), 0.0),
        settle_timeout_s=_float(el.get("settle_timeout_s"), 3600.0), poll_s=_float(el.get("poll_s"), 1.0),
        tolerance=_float(el.get("tolerance")), hold_s=_float(el.get("hold_s"), 0.0), protocol=proto,
    )


def serial_to_el(parent, tag, s: SerialInstrument):
    el = _set(etree.SubElement(parent, tag), name=s.name, port=s.port, baud=s.baud, bytesize=s.bytesize,
              parity=s.parity, stopbits=s.stopbits, timeout_s=s.timeout_s, min=s.min, max=s.max, unit=s.unit,
              settle_s=s.settle_s, settle_timeout_s=s.settle_timeout_s, poll_s=s.poll_s, tolerance=s.tolerance,
              hold_s=s.hold_s)
    if s.protocol is not None:
        protocol_to_el(el, s.protocol, _set)


@dataclass(frozen=True)
class Photodiode:
    """``<photodiode name port ... area_mm2 reading calibration samples>``: the calibrated
    reference photodiode of a spectral bench (EMVA 1288 4.0 Linear, Section 9.3), on a
    serial meter. ``reading``: "current" (A, turned into power by the calibration table's
    responsivity) or "power" (W, a power meter told the wavelength); ``calibration``: its
    table (A/W vs nm with uncertainties, ``ares.protocol.calibration``), relative to the
    system file, as written (``table``: loaded); ``samples``: readings averaged per stack."""

    serial: SerialInstrument
    area_mm2: float
    calibration: str
    reading: str = "current"
    samples: int = 5
    table: object = field(default=None, compare=False)  # ares.protocol.calibration.CalibrationTable


def photodiode_from_el(path, el) -> Photodiode | None:
    if el is None:
        return None
    from pathlib import Path

    from ares.errors import InputError
    from ares.protocol.calibration import load_calibration

    ser = serial_from_el(path, el, "photodiode")
    raw = el.get("calibration")
    where = Path(path).parent / raw
    if not where.is_file():
        raise fail(path, el.sourceline, f"<photodiode calibration='{raw}'>: {where.absolute()} not found")
    try:
        table = load_calibration(where)
    except InputError as exc:
        raise InputError(f"{exc} (the calibration table of <photodiode> at {path}:{el.sourceline})") from None
    return Photodiode(ser, float(el.get("area_mm2")), raw, el.get("reading", "current"), _int(el.get("samples"), 5),
                      table)


def photodiode_to_el(parent, p: Photodiode):
    serial_to_el(parent, "photodiode", p.serial)
    _set(parent[-1], area_mm2=p.area_mm2, reading=p.reading, calibration=p.calibration, samples=p.samples)


# ---------------------------------------------------------------- GenICam

@dataclass(frozen=True)
class Feature:
    """``<feature field node scale unit min max>``: register field ``field`` of the scan is the
    camera's GenICam feature ``node``; physical = scale x node value."""

    field: str
    node: str
    scale: float = 1.0
    unit: str = ""
    min: float | None = None
    max: float | None = None


@dataclass(frozen=True)
class GenICam:
    """``<genicam name cti device timeout_ms>``: a camera through a GenTL producer. ``cti``:
    the producer file (``genicam:NAME`` = a producer shipped inside the genicam package);
    ``device``: its id, serial number or index; ``<set node value>``: features written at
    open (pixel format, size); ``<feature>``: fields a scan sets."""

    name: str
    cti: str
    device: str = "0"
    timeout_ms: int = 3000
    sets: tuple[tuple[str, str], ...] = ()
    features: tuple[Feature, ...] = ()
    trigger: Trigger | None = None  # <trigger>: SFNC TriggerMode/TriggerSource/TriggerActivation, LineSource
    chunk_timestamp: bool = False  # the camera's chunk data carries each frame's time stamp (ChunkTimestamp)


def genicam_from_el(path, el) -> GenICam | None:
    if el is None:
        return None
    sets = tuple((s.get("node"), s.get("value")) for s in el.iterfind("set"))
    feats = tuple(Feature(f.get("field"), f.get("node"), _float(f.get("scale"), 1.0), f.get("unit", ""),
                          _float(f.get("min")), _float(f.get("max"))) for f in el.iterfind("feature"))
    names = [f.field for f in feats]
    if len(set(names)) != len(names):
        raise fail(path, el.sourceline, "<genicam> declares a <feature field=...> twice")
    return GenICam(el.get("name"), el.get("cti"), el.get("device", "0"), _int(el.get("timeout_ms"), 3000), sets, feats,
                   trigger_from_el(path, el.find("trigger")), _bool(el.get("chunk_timestamp")))


def genicam_to_el(parent, g: GenICam):
    el = _set(etree.SubElement(parent, "genicam"), name=g.name, cti=g.cti, device=g.device, timeout_ms=g.timeout_ms,
              chunk_timestamp=True if g.chunk_timestamp else None)
    for node, value in g.sets:
        _set(etree.SubElement(el, "set"), node=node, value=value)
    for f in g.features:
        _set(etree.SubElement(el, "feature"), field=f.field, node=f.node, scale=float(f.scale), unit=f.unit or None,
             min=f.min, max=f.max)
    trigger_to_el(el, g.trigger)
