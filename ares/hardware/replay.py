"""Replay bench: recorded images run through the scan path as if from live hardware.

A system XML with ``<replay descriptor="...EMVA1288_Data.txt"/>`` builds this bench
instead of the simulator or real devices (``ares.rig.factory.build_bench``):

- **registers** -- an in-memory register file over the system's own register map (a
  shim: writes are kept, reads return them); the field named by
  ``<controls exposure=...>`` selects the recorded exposure;
- **light** -- a virtual light source in photons/pixel/s (the simulator's unit, so the
  scan-level PTC's photons = light x exposure stays right). 0 selects the dark recording
  at the current exposure; a positive level selects the bright recording at that exposure
  whose recorded irradiance (photons per pixel / exposure) is within ``light_tolerance``
  (relative, default 1 %) of it;
- **frames** -- ``grab(n)`` delivers the first ``n`` images of the recording selected
  by the exposure register and the light level *at grab time* (the runner only writes
  the light when it changes). Where a photon-transfer pair and a longer stack were
  recorded at the same setting, the shortest recording with enough images is used.

Instead of a descriptor, ``<replay>`` may list ``<recording exposure="s" light="photons/pixel/s"
images="folder or glob"/>`` elements (any PNG/TIFF files, sorted by name; light 0 = dark):
:func:`descriptor_from_recordings` turns them into the same in-memory descriptor.

Asking for a setting that was not recorded, or for more frames than were recorded, is
an ``InputError`` naming the value, the nearest recorded ones and the descriptor file.
Each grab restarts at the recording's first image: grabbing a setting twice delivers the
same images (a replay cannot make new photons).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Iterator

from ares.errors import InputError
from ares.hardware.emva_descriptor import EmvaDescriptor, EmvaLevel, read_descriptor
from ares.hardware.imagefile import read_image
from ares.hardware.interfaces import Bench, Frame
from ares.hardware.registers import RegisterFile


class MemoryBus:
    """A register bus that remembers what was written (reads of unwritten registers: 0)."""

    def __init__(self, name: str = "replay"):
        self.name = name
        self.regs: dict[int, int] = {}

    def read(self, address: int) -> int:
        return self.regs.get(address, 0)

    def write(self, address: int, value: int) -> None:
        self.regs[address] = int(value)


def _fmt_s(seconds: float) -> str:
    return f"{seconds:.6g} s"


def _nearest(values: list[float], x: float, k: int = 3) -> list[float]:
    return sorted(sorted(set(values), key=lambda v: (abs(v - x), v))[:k])


class ReplayLight:
    """``LightSource`` of a replay bench: remembers the level; selection happens at grab time."""

    def __init__(self, name: str = "replay_light"):
        self.name = name
        self._level = 0.0

    def set_level(self, level: float) -> None:
        if not math.isfinite(level) or level < 0:
            raise InputError(f"{self.name}: light level must be a finite number >= 0, got {level}")
        self._level = float(level)

    def get_level(self) -> float:
        return self._level

    def settle(self, cancel=None) -> None:
        pass


class ReplayFrameSource:
    """``FrameSource`` over an EMVA 1288 descriptor, selected by exposure register + light."""

    exposure_paced = False  # files are read, not exposed
    recorded = True  # nothing settles: the frames are what was recorded (no probe frames, ares.scan.settling)

    def __init__(self, descriptor: EmvaDescriptor, registers: RegisterFile, exposure_field: str,
                 light: ReplayLight, light_tolerance: float = 0.01, name: str | None = None):
        self.descriptor = descriptor
        self.registers = registers
        self.exposure_field = exposure_field
        self.light = light
        self.light_tolerance = light_tolerance
        self.name = name or f"replay:{descriptor.path.name}"
        self.shape = (descriptor.height, descriptor.width)
        self.bit_depth = descriptor.bits
        self._count = 0

    # -- selection ------------------------------------------------------------
    def exposure_s(self) -> float:
        return self.registers.get(self.exposure_field)

    def select(self, exposure_s: float, light: float, n: int) -> EmvaLevel:
        """The recording at ``exposure_s`` and ``light`` (photons/pixel/s, 0 = dark) with
        at least ``n`` images; ``InputError`` (one sentence) when there is none."""
        d = self.descriptor
        src = f"(recorded data: {d.path})"
        exp_ns = exposure_s * 1e9
        at_exp = [lv for lv in d.levels if math.isclose(lv.exposure_ns, exp_ns, rel_tol=1e-6, abs_tol=0.5)]
        if not at_exp:
            near = ", ".join(_fmt_s(v * 1e-9) for v in _nearest([lv.exposure_ns for lv in d.levels], exp_ns))
            raise InputError(f"{self.name}: no recording at exposure {_fmt_s(exposure_s)}; the nearest recorded "
                             f"exposures are {near} {src}")
        if light == 0:
            cands = [lv for lv in at_exp if lv.dark]
            if not cands:
                raise InputError(f"{self.name}: no dark recording at exposure {_fmt_s(exposure_s)} (only bright "
                                 f"ones) {src}")
            what = "dark"
        else:
            bright = [lv for lv in at_exp if not lv.dark]
            if not bright:
                raise InputError(f"{self.name}: no bright recording at exposure {_fmt_s(exposure_s)} (only dark "
                                 f"ones) {src}")
            rates = {lv: lv.photons / lv.exposure_s for lv in bright}
            cands = [lv for lv in bright if abs(rates[lv] - light) <= self.light_tolerance * light]
            if not cands:
                near = ", ".join(f"{r:.6g}" for r in _nearest(list(rates.values()), light))
                raise InputError(f"{self.name}: no recording at light level {light:.6g} photons/pixel/s and "
                                 f"exposure {_fmt_s(exposure_s)} (within {100 * self.light_tolerance:g} %); "
                                 f"recorded there: {near} photons/pixel/s {src}")
            what = f"bright ({light:.6g} photons/pixel/s)"
        enough = [lv for lv in cands if len(lv.images) >= n]
        if not enough:
            most = max(cands, key=lambda lv: len(lv.images))
            raise InputError(f"{self.name}: the scan asks for {n} frames at exposure {_fmt_s(exposure_s)}, {what}, "
                             f"but only {len(most.images)} were recorded ({d.path}:{most.line}); ask for at most "
                             f"{len(most.images)} frames (frames= / dark_frames=)")
        return min(enough, key=lambda lv: (len(lv.images), lv.line))

    def grab(self, n: int) -> Iterator[Frame]:
        lv = self.select(self.exposure_s(), self.light.get_level(), n)
        for p in lv.images[:n]:
            data = read_image(p)
            if data.shape != self.shape:
                raise InputError(f"{p}: image is {data.shape[1]}x{data.shape[0]}, the descriptor "
                                 f"{self.descriptor.path} declares {self.shape[1]}x{self.shape[0]}")
            meta = {"exposure_s": lv.exposure_s, "photons": lv.photons, "dark": lv.dark,
                    "descriptor_line": lv.line, "path": str(p)}
            yield Frame(data=data, index=self._count, timestamp=float(self._count), meta=meta)
            self._count += 1

    def close(self) -> None:
        pass


IMAGE_SUFFIXES = (".png", ".tif", ".tiff")


def descriptor_from_recordings(system) -> EmvaDescriptor:
    """The ``<recording>`` list of a replay system as an in-memory descriptor (levels keyed
    by exposure and light; photons = light x exposure; lines are the system file's)."""
    r = system.replay
    levels = []
    for rec in r.recordings:
        where = f"{system.source}:{rec.line}"
        p = Path(rec.images).expanduser()
        p = p if p.is_absolute() else r.path / p
        if p.is_dir():
            files = sorted(f for f in p.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES and f.is_file())
            looked = f"in the folder {p}"
        elif any(c in rec.images for c in "*?["):
            rel = Path(rec.images)
            if rel.is_absolute():
                files = sorted(Path(rel.anchor).glob(str(rel.relative_to(rel.anchor))))
            else:
                files = sorted(r.path.glob(rec.images))
            files = [f for f in files if f.suffix.lower() in IMAGE_SUFFIXES and f.is_file()]
            looked = f"for the pattern {p}"
        elif p.is_file():
            files, looked = [p], str(p)
        else:
            how = f" (relative to ${r.env})" if r.from_env else ""
            raise InputError(f"{where}: <recording images='{rec.images}'>: {p} not found{how}")
        if not files:
            raise InputError(f"{where}: <recording images='{rec.images}'> finds no PNG/TIFF files {looked}")
        levels.append(EmvaLevel(rec.light == 0, rec.exposure * 1e9, rec.light * rec.exposure, tuple(files), rec.line))
    s = system.sensor
    return EmvaDescriptor(Path(system.source), "", s.adc_bits, s.cols, s.rows, tuple(levels),
                          f"recorded images ({len(levels)} recordings, {system.source})")


def build_replay_bench(system) -> Bench:
    """The bench of a ``<replay>`` system (its data checked by ``replay_descriptor``)."""
    return _bench(system, replay_descriptor(system))


def replay_descriptor(system) -> EmvaDescriptor:
    """The recorded data a ``<replay>`` system names, read and checked against <sensor>; a
    missing descriptor (or recording) is one sentence naming the system file, the line and
    the path looked for. ``ares validate`` and ``ares run``'s preflight call it too, so a
    scan whose data is missing is refused before a run directory exists."""
    r = system.replay
    if r.recordings:
        return descriptor_from_recordings(system)
    if not r.path.is_file():
        how = (f"from ${r.env}" if r.from_env else
               f"'{r.descriptor}'" + (f"; set ${r.env} to override" if r.env else ""))
        raise InputError(f"{r.where()}: <replay> descriptor {r.path} not found ({how})")
    try:
        desc = read_descriptor(r.path)
    except InputError as exc:
        raise InputError(f"{r.where()}: <replay> descriptor: {exc}") from None
    want = (system.sensor.rows, system.sensor.cols, system.sensor.adc_bits)
    if (desc.height, desc.width, desc.bits) != want:
        raise InputError(f"{r.where()}: <replay> descriptor {desc.path} records {desc.width}x{desc.height} "
                         f"{desc.bits}-bit images but <sensor> declares {want[1]}x{want[0]} {want[2]}-bit")
    return desc


def _sha256(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def relocate_replay(system, bench_meta: dict | None):
    """The system of a recorded run, its data found where the run found it: the run
    directory keeps the system XML verbatim, so a relative ``descriptor=`` (or recording
    folder) now points below the run's ``xml/``. ``run.json`` keeps the absolute path the
    run used (``replay_path``) and the descriptor's SHA-256; where the XML-relative path is
    missing (and no environment variable chose another), that path is used, and a
    descriptor whose content changed since is refused in one sentence."""
    r = getattr(system, "replay", None)
    if r is None or not bench_meta or r.from_env or not bench_meta.get("replay_path"):
        return system
    import dataclasses

    recorded = Path(bench_meta["replay_path"])
    if r.path.exists() or not recorded.exists():
        return system  # (missing at both: the bench says so, naming the XML's path)
    want = bench_meta.get("replay_sha256")
    if want and recorded.is_file() and _sha256(recorded) != want:
        raise InputError(f"{recorded}: the recorded data's descriptor changed since the run (SHA-256 differs "
                         "from run.json's); the run cannot be repeated on it")
    return dataclasses.replace(system, replay=dataclasses.replace(r, path=recorded))


def _bench(system, desc: EmvaDescriptor) -> Bench:
    r = system.replay
    regs = RegisterFile(system.registers, MemoryBus(f"{system.name}:registers"))
    for f in system.registers.fields:  # power-on defaults, as a real sensor would have
        if f.access != "ro" and f.default:
            regs.set_raw(f.name, f.default)
    light = ReplayLight(f"{system.name}:light")
    frames = ReplayFrameSource(desc, regs, system.controls.exposure, light, r.light_tolerance,
                               name=f"replay '{system.name}'")
    info = {"system": system.name, "replay_descriptor": str(desc.path), "attribution": desc.attribution,
            "recorded_levels": len(desc.levels), "replay_path": str(r.path),
            "replay_sha256": _sha256(r.path) if r.path.is_file() else None}
    return Bench(regs, frames, light, None, info)
