"""Physical-system description (``protocols/*.xml``) as frozen dataclasses.

``load_system(path) -> System`` validates the file against ``schemas/system.xsd`` and
checks what a schema cannot (register fields fit, controls name real fields, regions
fit the array); ``save_system(system, path)`` writes an equivalent file.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from ares.errors import InputError
from ares.hardware.registers import Field, RegisterMap
from ares.protocol import xmlsafe
from ares.protocol.devices import (GenICam, I2CBus, Photodiode, SerialInstrument, UsbGrabber, _bool, _float, _int, _set,
                                   check_buses, check_simulated_trigger, genicam_from_el, group_hold_from_el, genicam_to_el, i2c_from_el, i2c_to_el, photodiode_from_el,
                                   photodiode_to_el, serial_from_el, serial_to_el,
                                   usb_from_el, usb_to_el)
from ares.protocol.settle import Settle, settle_from_el, settle_to_el
from ares.protocol.xmlsafe import fail


@dataclass(frozen=True)
class Region:
    name: str
    x: int
    y: int
    width: int
    height: int

    def slices(self) -> tuple[slice, slice]:
        """(rows, cols) slices into a frame."""
        return slice(self.y, self.y + self.height), slice(self.x, self.x + self.width)


@dataclass(frozen=True)
class Sensor:
    name: str
    rows: int
    cols: int
    cfa: str = "mono"
    adc_bits: int = 12
    adc_channels: int = 1
    adc_interleave: str = "none"
    pixel_pitch_um: float | None = None
    vendor: str | None = None
    part: str | None = None
    optical_black: tuple[Region, ...] = ()
    # <gain dn_per_e se source>: a system gain known from a calibration, for scans that measure
    # none (dark currents in e-/s on the temperature scan); a PTC in the run takes precedence
    gain_dn_per_e: float | None = None
    gain_se: float | None = None
    gain_source: str | None = None


@dataclass(frozen=True)
class Controls:
    """Which register fields carry the scan quantities ``exposure``/``analog_gain``/``black_level``."""

    exposure: str | None = None
    analog_gain: str | None = None
    black_level: str | None = None


@dataclass(frozen=True)
class Timing:
    readout_s: float = 0.0  # per frame, on top of the exposure (durations, read timeouts)
    settle_s: float = 0.0  # wait after a register change before the stage's frames
    discard_frames: int = 0  # frames grabbed and dropped after a register change (exposed at the old settings)
    flush: bool = False  # drain what the frame source holds before every stack
    margin_s: float = 0.5  # read timeouts: at least exposure + readout_s + margin_s
    after: tuple = ()  # (quantity, settle_s, discard_frames): <after quantity="registers|light|temperature|wavelength">
    settle: Settle = Settle()  # <settle>: settling proven by the frames (ares.protocol.settle)
    frames_in_flight: int | None = None  # frames the grabber/sensor pipeline can hold (None: undeclared, 1 assumed)

    def after_change(self, quantity: str) -> tuple[float, int]:
        """(settle seconds, frames to discard) after ``quantity`` changed ("registers",
        "light", "temperature", "wavelength"): its ``<after>`` element, else the register defaults for
        registers and nothing for an instrument (its own settle is in its device element)."""
        for q, settle, discard in self.after:
            if q == quantity:
                return settle, discard
        return (self.settle_s, self.discard_frames) if quantity == "registers" else (0.0, 0)


@dataclass(frozen=True)
class Simulator:
    seed: int = 0
    params: dict = field(default_factory=dict)  # typed values for ares.sim.SensorParams.from_dict
    wire: bool = False  # behind emulators of the declared I2C bus, USB grabber and serial instruments
    paced: bool = False  # frames delivered at the sensor's frame period (exposure + <timing readout_s>)


IN_FLIGHT_CAP = 16  # <timing frames_in_flight> at most (ares.scan.in_flight.CAP: a grabber's FIFO)
REPLAY_LIGHT_PORT = "replay"  # port of the virtual light source a replay system presents


@dataclass(frozen=True)
class Recording:
    """``<recording exposure= light= images=>``: the images recorded at one setting; ``images``
    is a folder (its PNG/TIFF files, sorted by name) or a glob pattern, relative to the
    system file (or to the folder ``$env`` names)."""

    exposure: float  # s
    light: float  # photons/pixel/s; 0 = dark
    images: str
    line: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Replay:
    """``<replay descriptor= env= light_tolerance=>``: recorded data (an EMVA 1288
    descriptor file) instead of a sensor. ``path`` is the resolved descriptor (the
    environment variable ``env`` names wins when set; a relative path is relative to the
    system file -- saved as written, so a copied system file looks relative to its new
    folder; a folder means its ``EMVA1288_Data.txt``). Whether it exists is checked
    when the bench is built (``ares.hardware.replay``), so a system file stays valid on a
    machine without the data; where it exists, ``load_system`` checks it against <sensor>."""

    descriptor: str  # as written in the XML (saved as written, like a scan's system href); "" with recordings
    path: Path = field(default=None, compare=False)  # resolved when loaded
    env: str | None = None
    light_tolerance: float = 0.01  # relative: light level vs the recorded photons/pixel/s
    line: int = field(default=0, compare=False)  # line of <replay> (for error messages)
    source: Path | None = field(default=None, compare=False)  # the system file
    from_env: bool = field(default=False, compare=False)
    recordings: tuple[Recording, ...] = ()  # instead of a descriptor: image folders per setting

    def where(self) -> str:
        return f"{self.source}:{self.line}" if self.line else str(self.source)


def resolve_replay_path(descriptor: str, env: str | None, base: Path) -> tuple[Path, bool]:
    """(descriptor file, taken from the environment?) -- see :class:`Replay`."""
    raw, from_env = descriptor, False
    if env and os.environ.get(env, "").strip():
        raw, from_env = os.environ[env].strip(), True
    p = Path(os.path.expanduser(raw))
    if not p.is_absolute():
        p = (Path.cwd() if from_env else base) / p
    p = Path(os.path.normpath(p.absolute()))
    if p.is_dir():
        p = p / "EMVA1288_Data.txt"
    return p, from_env


@dataclass(frozen=True)
class System:
    name: str
    sensor: Sensor
    registers: RegisterMap
    version: int = 1
    description: str = ""
    controls: Controls = Controls()
    timing: Timing = Timing()
    buses: tuple[I2CBus, ...] = ()
    usb_grabber: UsbGrabber | None = None
    light_source: SerialInstrument | None = None
    chamber: SerialInstrument | None = None
    monochromator: SerialInstrument | None = None  # spectral bench: wavelength-selectable light (nm)
    photodiode: Photodiode | None = None  # spectral bench: the calibrated reference photodiode
    genicam: GenICam | None = None
    simulator: Simulator | None = None
    replay: Replay | None = None
    source: Path | None = field(default=None, compare=False)

    def control_field(self, quantity: str) -> Field | None:
        name = getattr(self.controls, quantity, None)
        return self.registers.field(name) if name else None

    def setting_units(self) -> dict[str, str]:
        """Unit of every setting a stage can carry: register fields (``reg:sf_bias`` -> V,
        as the register map declares), ``exposure`` (s, or its control field's unit),
        ``analog_gain`` (x), ``light`` (the light source's unit; photons/pixel/s on the
        simulator) and ``temperature`` (C). The one source for axis labels and CSV columns."""
        out = {f"reg:{f.name}": f.unit for f in (self.registers.fields if self.registers else ()) if f.unit}
        for q, default in (("exposure", "s"), ("analog_gain", "x")):
            f = self.control_field(q)
            out[q] = f.unit if f is not None and f.unit else default
        dev = self.light_source
        out["light"] = dev.unit if dev is not None and dev.unit else "photons/pixel/s"
        out["temperature"] = "C"
        if self.monochromator is not None:
            out["wavelength"] = self.monochromator.unit or "nm"
        return {k: v for k, v in out.items() if v}


# ---------------------------------------------------------------- loading

def _region(el) -> Region:
    return Region(el.get("name"), int(el.get("x")), int(el.get("y")), int(el.get("width")), int(el.get("height")))


def _check_region(path, el, r: Region, rows: int, cols: int, what: str):
    if r.x + r.width > cols or r.y + r.height > rows:
        raise fail(path, el.sourceline, f"{what} '{r.name}' ({r.x},{r.y} {r.width}x{r.height}) "
                                        f"does not fit in the {cols}x{rows} array")


def _param(path, el):
    name, value, typ = el.get("name"), el.get("value"), el.get("type")
    try:
        if typ == "int":
            return name, _int(value)
        if typ == "float":
            return name, float(value)
        if typ == "floats":
            return name, tuple(float(x) for x in value.split())
        if typ == "bool":
            if value.strip() not in ("true", "false", "1", "0"):
                raise ValueError
            return name, value.strip() in ("true", "1")
    except ValueError:
        raise fail(path, el.sourceline, f"simulator parameter '{name}' must be of type {typ}, got '{value}'") from None
    return name, value


def _fields(path, reg_el, address_bits: int, value_bits: int) -> tuple[Field, ...]:
    out = []
    for el in reg_el.iterfind("field"):
        f = Field(
            name=el.get("name"), address=_int(el.get("address")), lsb=_int(el.get("lsb"), 0),
            msb=_int(el.get("msb")), count=_int(el.get("count"), 1), access=el.get("access", "rw"),
            scale=_float(el.get("scale"), 1.0), offset=_float(el.get("offset"), 0.0), unit=el.get("unit", ""),
            minimum=_float(el.get("min")), maximum=_float(el.get("max")), default=_int(el.get("default"), 0),
            description=el.get("description", ""), volatile=el.get("volatile", "false").strip() in ("true", "1"),
            signed=el.get("signed", "false").strip() in ("true", "1"), bus=el.get("bus"),
            buffered=el.get("buffered"), shadow=_int(el.get("shadow")),
        )
        line = el.sourceline
        if f.lsb > f.msb:
            raise fail(path, line, f"register field '{f.name}': lsb {f.lsb} is above msb {f.msb}")
        if f.count * value_bits > 64:
            raise fail(path, line, f"register field '{f.name}' spans {f.count} registers of {value_bits} bits "
                                   f"({f.count * value_bits} bits); a field holds at most 64 bits")
        if f.msb >= value_bits * f.count:
            raise fail(path, line, f"register field '{f.name}': bit {f.msb} does not fit in {f.count} "
                                   f"register(s) of {value_bits} bits")
        if f.address + f.count > (1 << address_bits):
            raise fail(path, line, f"register field '{f.name}': address 0x{f.address:x} is outside the "
                                   f"{address_bits}-bit address space")
        if f.scale == 0:
            raise fail(path, line, f"register field '{f.name}': scale must not be 0")
        if f.minimum is not None and f.maximum is not None and f.minimum > f.maximum:
            raise fail(path, line, f"register field '{f.name}': min {f.minimum:g} is above max {f.maximum:g}")
        if f.default >= (1 << f.width):
            raise fail(path, line, f"register field '{f.name}': default {f.default} does not fit in {f.width} bits")
        out.append(f)
    return tuple(out)


def system_from_tree(tree, path) -> System:
    root = tree.getroot()
    s = root.find("sensor")
    arr = s.find("array")
    rows, cols = int(arr.get("rows")), int(arr.get("cols"))
    if root.find("simulator") is not None:
        from ares.sim.ranges import array_problem

        why = array_problem(rows, cols)
        if why:
            raise fail(path, arr.sourceline, why)
    ob = []
    for el in s.iterfind("optical_black/region"):
        r = _region(el)
        _check_region(path, el, r, rows, cols, "optical-black region")
        ob.append(r)
    adc = s.find("adc")
    g = s.find("gain")
    sensor = Sensor(
        name=s.get("name"), rows=rows, cols=cols, cfa=s.find("cfa").get("pattern"),
        adc_bits=int(adc.get("bits")), adc_channels=int(adc.get("channels", 1)),
        adc_interleave=adc.get("interleave", "none"), pixel_pitch_um=_float(arr.get("pixel_pitch_um")),
        vendor=s.get("vendor"), part=s.get("part"), optical_black=tuple(ob),
        gain_dn_per_e=_float(g.get("dn_per_e")) if g is not None else None,
        gain_se=_float(g.get("se")) if g is not None else None, gain_source=g.get("source") if g is not None else None,
    )
    if sensor.adc_channels > 1 and sensor.adc_interleave == "none":
        raise fail(path, adc.sourceline, f"<adc> has {sensor.adc_channels} channels but interleave='none'; "
                                         "say how they share the array (column, row or pixel)")
    reg = root.find("registers")
    if reg is not None:
        abits, vbits = int(reg.get("address_bits")), int(reg.get("value_bits"))
        fields = _fields(path, reg, abits, vbits)
        try:
            regmap = RegisterMap(abits, vbits, reg.get("endian", "big"), fields, reg.get("bus"), group_hold_from_el(reg),
                                 reg.get("read_latch"))
        except InputError as exc:
            raise fail(path, reg.sourceline, str(exc)) from None
    elif root.find("devices/genicam") is not None:  # the camera's features are its fields
        from ares.hardware.genicam import feature_map

        regmap = feature_map(genicam_from_el(path, root.find("devices/genicam")))
    else:
        raise fail(path, root.sourceline, "<registers> is missing (only a <genicam> camera may leave it out: "
                                          "its <feature> elements are its fields)")
    ctl = root.find("controls")
    controls = Controls()
    if ctl is not None:
        controls = Controls(ctl.get("exposure"), ctl.get("analog_gain"), ctl.get("black_level"))
        for q in ("exposure", "analog_gain", "black_level"):
            name = getattr(controls, q)
            if name and name not in regmap.names():
                raise fail(path, ctl.sourceline, f"<controls {q}='{name}'> names no register field "
                                                 f"(known: {', '.join(regmap.names())})")
    tim = root.find("timing")
    timing = Timing() if tim is None else Timing(
        _float(tim.get("readout_s"), 0.0), _float(tim.get("settle_s"), 0.0), int(tim.get("discard_frames", 0)),
        tim.get("flush", "false") in ("true", "1"), _float(tim.get("margin_s"), 0.5),
        tuple((a.get("quantity"), _float(a.get("settle_s"), 0.0), int(a.get("discard_frames", 0)))
              for a in tim.iterfind("after")), settle_from_el(path, tim.find("settle")),
        None if tim.get("frames_in_flight") is None else _int(tim.get("frames_in_flight"), 1))
    if timing.frames_in_flight is not None and not 1 <= timing.frames_in_flight <= IN_FLIGHT_CAP:
        raise fail(path, tim.sourceline, f"<timing frames_in_flight='{timing.frames_in_flight}'> must be 1 .. "
                                         f"{IN_FLIGHT_CAP} (the frames a grabber and sensor can hold in flight)")
    buses = tuple(i2c_from_el(path, el) for el in root.iterfind("buses/i2c"))
    check_buses(path, root, buses, regmap)
    g = root.find("devices/usb_grabber")
    grabber = None if g is None else usb_from_el(path, g)
    cam = genicam_from_el(path, root.find("devices/genicam"))
    sim_el = root.find("simulator")
    sim = None
    if sim_el is not None:
        sim = Simulator(_int(sim_el.get("seed"), 0), dict(_param(path, p) for p in sim_el.iterfind("param")),
                        _bool(sim_el.get("wire"), False), _bool(sim_el.get("paced"), False))
        if sim.paced and sim.wire:
            raise fail(path, sim_el.sourceline, "<simulator paced=\"true\"> applies to the direct simulator; "
                                                "behind the wires (wire=\"true\") frames come as fast as they are made")
        check_simulated_trigger(path, root, sim.wire)
    light = serial_from_el(path, root.find("devices/light_source"), "light_source")
    rep_el = root.find("replay")
    replay = None
    if rep_el is not None:
        replay = _replay(path, rep_el, root, sensor, controls, regmap)
        light = SerialInstrument(name="replay_light", port=REPLAY_LIGHT_PORT, unit="photons/pixel/s", min=0.0)
    desc = root.find("description")
    return System(
        name=root.get("name"), version=_int(root.get("version"), 1),
        description=(desc.text or "").strip() if desc is not None else "",
        sensor=sensor, registers=regmap, controls=controls, timing=timing, buses=buses, usb_grabber=grabber,
        light_source=light, chamber=serial_from_el(path, root.find("devices/chamber"), "chamber"), genicam=cam,
        monochromator=serial_from_el(path, root.find("devices/monochromator"), "monochromator"),
        photodiode=photodiode_from_el(path, root.find("devices/photodiode")),
        simulator=sim, replay=replay, source=Path(path),
    )


def _replay(path, el, root, sensor: Sensor, controls: Controls, regmap: RegisterMap) -> Replay:
    """``<replay>``: no simulator or devices beside it, an exposure control, and (when the
    descriptor is present) a descriptor that matches <sensor>."""
    line = el.sourceline
    for other in ("simulator", "buses", "devices"):
        if root.find(other) is not None:
            raise fail(path, root.find(other).sourceline,
                       f"a <replay> system replays recorded data and cannot also declare <{other}>")
    if controls.exposure is None:
        raise fail(path, line, "a <replay> system needs <controls exposure=...> naming the register field "
                               "that selects the recorded exposure")
    f = regmap.field(controls.exposure)
    if f.access != "rw":
        raise fail(path, line, f"<replay>: the exposure field '{f.name}' must be read-write (access='rw')")
    desc, env = (el.get("descriptor") or "").strip(), el.get("env")
    tol = _float(el.get("light_tolerance"), 0.01)
    recs = tuple(Recording(float(r.get("exposure")), float(r.get("light")), r.get("images").strip(), r.sourceline)
                 for r in el.iterfind("recording"))
    if recs:
        if el.get("descriptor") is not None:
            raise fail(path, line, "<replay> takes either descriptor=... or <recording> elements, not both")
        seen: dict = {}
        for r in recs:
            if not r.images:
                raise fail(path, r.line, "<recording images=...> is empty; give a folder or a glob pattern")
            key = (r.exposure, r.light)
            if key in seen:
                raise fail(path, r.line, f"<recording> at exposure {r.exposure:g} s and light {r.light:g} repeats "
                                         f"line {seen[key]}")
            seen[key] = r.line
        base, from_env = Path(path).parent, False
        if env and os.environ.get(env, "").strip():
            base, from_env = Path(os.path.expanduser(os.environ[env].strip())), True
        base = Path(os.path.normpath(base.absolute()))
        return Replay("", base, env, tol, line, Path(path), from_env, recs)
    if not desc:
        raise fail(path, line, "<replay> needs descriptor=... (an EMVA 1288 descriptor file) or <recording> elements")
    p, from_env = resolve_replay_path(desc, env, Path(path).parent)
    rp = Replay(desc, p, env, tol, line, Path(path), from_env)
    if p.is_file():
        from ares.hardware.emva_descriptor import read_descriptor

        try:
            d = read_descriptor(p, check_files=False)
        except InputError as exc:
            raise fail(path, line, f"<replay> descriptor: {exc}") from None
        if (d.height, d.width, d.bits) != (sensor.rows, sensor.cols, sensor.adc_bits):
            raise fail(path, line, f"<replay> descriptor {p} records {d.width}x{d.height} {d.bits}-bit images but "
                                   f"<sensor> declares {sensor.cols}x{sensor.rows} {sensor.adc_bits}-bit")
    return rp


def load_system(path: str | Path) -> System:
    """Load and check a system XML; raises ``InputError`` with ``file:line: sentence``."""
    return system_from_tree(xmlsafe.load(path, "system"), path)


# ---------------------------------------------------------------- saving

def system_to_tree(sy: System) -> etree._ElementTree:
    root = _set(etree.Element("system"), name=sy.name, version=sy.version)
    if sy.description:
        etree.SubElement(root, "description").text = sy.description
    s = sy.sensor
    se = _set(etree.SubElement(root, "sensor"), name=s.name, vendor=s.vendor, part=s.part)
    _set(etree.SubElement(se, "array"), rows=s.rows, cols=s.cols, pixel_pitch_um=s.pixel_pitch_um)
    if s.optical_black:
        ob = etree.SubElement(se, "optical_black")
        for r in s.optical_black:
            _set(etree.SubElement(ob, "region"), name=r.name, x=r.x, y=r.y, width=r.width, height=r.height)
    _set(etree.SubElement(se, "cfa"), pattern=s.cfa)
    _set(etree.SubElement(se, "adc"), bits=s.adc_bits, channels=s.adc_channels, interleave=s.adc_interleave)
    if s.gain_dn_per_e is not None:
        _set(etree.SubElement(se, "gain"), dn_per_e=s.gain_dn_per_e, se=s.gain_se, source=s.gain_source)
    m = sy.registers
    if sy.genicam is not None:
        from ares.hardware.genicam import feature_map

        if m == feature_map(sy.genicam):
            m = None  # derived from the <feature> elements: not written twice
    re_ = None if m is None else _set(etree.SubElement(root, "registers"), address_bits=m.address_bits,
                                      value_bits=m.value_bits, endian=m.endian, bus=m.bus, read_latch=m.read_latch)
    if m is not None and m.group_hold is not None:
        _set(etree.SubElement(re_, "group_hold"), register=f"0x{m.group_hold[0]:04X}", hold=f"0x{m.group_hold[1]:X}",
             release=f"0x{m.group_hold[2]:X}")
    for f in (m.fields if m is not None else ()):
        _set(etree.SubElement(re_, "field"), name=f.name, address=f"0x{f.address:04X}", lsb=f.lsb, msb=f.msb,
             count=f.count, access=f.access, scale=float(f.scale), offset=float(f.offset), unit=f.unit or None,
             min=None if f.minimum is None else float(f.minimum), max=None if f.maximum is None else float(f.maximum),
             default=f.default, description=f.description or None, volatile=True if f.volatile else None,
             signed=True if f.signed else None, bus=f.bus, buffered=f.buffered,
             shadow=None if f.shadow is None else f"0x{f.shadow:04X}")
    c = sy.controls
    if c != Controls():
        _set(etree.SubElement(root, "controls"), exposure=c.exposure, analog_gain=c.analog_gain, black_level=c.black_level)
    if sy.timing != Timing():
        t = sy.timing
        te = _set(etree.SubElement(root, "timing"), readout_s=float(t.readout_s), settle_s=float(t.settle_s),
                  discard_frames=t.discard_frames or None, flush="true" if t.flush else None,
                  margin_s=None if t.margin_s == 0.5 else t.margin_s, frames_in_flight=t.frames_in_flight)
        for q, settle, discard in t.after:
            _set(etree.SubElement(te, "after"), quantity=q, settle_s=settle, discard_frames=discard or None)
        settle_to_el(te, t.settle, etree.SubElement)
    if sy.buses:
        b = etree.SubElement(root, "buses")
        for bus in sy.buses:
            i2c_to_el(b, bus)
    if sy.usb_grabber or sy.genicam or (sy.light_source and not sy.replay) or sy.chamber or sy.monochromator \
            or sy.photodiode:
        d = etree.SubElement(root, "devices")
        if sy.usb_grabber:
            usb_to_el(d, sy.usb_grabber)
        if sy.genicam:
            genicam_to_el(d, sy.genicam)
        if sy.light_source and not sy.replay:
            serial_to_el(d, "light_source", sy.light_source)
        if sy.chamber:
            serial_to_el(d, "chamber", sy.chamber)
        if sy.monochromator:
            serial_to_el(d, "monochromator", sy.monochromator)
        if sy.photodiode:
            photodiode_to_el(d, sy.photodiode)
    if sy.simulator:
        sim = _set(etree.SubElement(root, "simulator"), seed=sy.simulator.seed, wire=sy.simulator.wire or None,
                   paced=sy.simulator.paced or None)
        for k, v in sy.simulator.params.items():
            t = {bool: "bool", int: "int", float: "float", tuple: "floats"}.get(type(v), "str")
            v = " ".join(repr(float(x)) for x in v) if t == "floats" else v
            _set(etree.SubElement(sim, "param"), name=k, value=v, type=t)
    if sy.replay:
        r = sy.replay
        rel = _set(etree.SubElement(root, "replay"), descriptor=r.descriptor or None, env=r.env,
                   light_tolerance=float(r.light_tolerance))
        for rec in r.recordings:
            _set(etree.SubElement(rel, "recording"), exposure=float(rec.exposure), light=float(rec.light),
                 images=rec.images)
    return etree.ElementTree(root)


def save_system(sy: System, path: str | Path) -> None:
    tree = system_to_tree(sy)
    etree.indent(tree, space="  ")
    Path(path).write_bytes(etree.tostring(tree, xml_declaration=True, encoding="UTF-8", pretty_print=True))
