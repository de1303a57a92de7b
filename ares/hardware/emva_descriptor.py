"""EMVA 1288 descriptor files: reader and a replay ``FrameSource``.

Descriptor format (EMVA 1288 Release 3.0 reference data sets), one record a line,
``#`` starts a comment line:

- ``v VERSION``; ``n BITS WIDTH HEIGHT`` (once);
- ``b EXPOSURE_NS PHOTONS_PER_PIXEL`` then its images (``i PATH``) -- bright level;
- ``d EXPOSURE_NS`` then its images -- dark level;
- ``i PATH`` image of the level opened by the previous ``b``/``d`` record; paths may use
  backslashes and are relative to the descriptor's folder.

What a lab measures instead of photon counts (ARES's extension; ``ares emva --wavelength-nm
--pixel-size-um --detector-area-mm2`` give the same constants on the command line):

- ``b EXPOSURE_NS E=IRRADIANCE`` -- the irradiance at the sensor plane in W/m^2, or
  ``b EXPOSURE_NS P=POWER`` -- a power-meter reading in W over its detector area;
- ``w WAVELENGTH_NM`` (the light's centroid wavelength, Linear Section 6.2), ``a PIXEL_AREA_UM2``
  and, for ``P=``, ``m DETECTOR_AREA_MM2`` (once each, anywhere in the file).

The photons per pixel follow from EMVA 1288 4.0 Linear Eq. (3), mu_p = A E t_exp lambda / (h c)
(Eq. (4) is the same in lab units), E = P / A_detector for a power meter (Section 6.4); the
descriptor keeps the inputs (``EmvaDescriptor.radiometry``) so that a result implying a quantum
efficiency outside 0 - 100 % can be refused with the numbers (``ares.results.descriptor``).

A level with two images belongs to the photon-transfer (temporal) series; one with more
belongs to the spatial non-uniformity stacks -- the convention of the EMVA reference
implementation. Every malformed record raises ``InputError`` naming ``file:line``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path, PureWindowsPath
from typing import Iterator, Sequence

import numpy as np

from ares.errors import InputError
from ares.hardware.imagefile import read_image
from ares.safefile import Confinement, read_regular
from ares.hardware.interfaces import Frame


@dataclass(frozen=True)
class EmvaLevel:
    """One ``b``/``d`` record with its images."""

    dark: bool
    exposure_ns: float
    photons: float  # mean photons per pixel during the exposure; 0 for dark
    images: tuple[Path, ...]
    line: int  # line number of the b/d record in the descriptor

    @property
    def exposure_s(self) -> float:
        return self.exposure_ns * 1e-9

    @property
    def kind(self) -> str:
        """``"temporal"`` (a pair) or ``"spatial"`` (a longer stack)."""
        return "temporal" if len(self.images) == 2 else "spatial"


@dataclass(frozen=True)
class EmvaDescriptor:
    path: Path
    version: str
    bits: int
    width: int
    height: int
    levels: tuple[EmvaLevel, ...] = field(default_factory=tuple)
    attribution: str = ""  # the line shown with results derived from the data
    radiometry: "Radiometry | None" = None  # the lab's inputs when the photon counts were converted
    pixel_area_um2: float | None = None  # an 'a' record (the per-area figures)
    wavelength_nm: float | None = None  # a 'w' record

    def select(self, kind: str, dark: bool) -> list[EmvaLevel]:
        return [lv for lv in self.levels if lv.kind == kind and lv.dark == dark]

    @property
    def temporal_bright(self) -> list[EmvaLevel]:
        return sorted(self.select("temporal", False), key=lambda lv: (lv.exposure_ns, lv.photons))

    @property
    def temporal_dark(self) -> list[EmvaLevel]:
        return sorted(self.select("temporal", True), key=lambda lv: lv.exposure_ns)

    @property
    def spatial_bright(self) -> list[EmvaLevel]:
        return self.select("spatial", False)

    @property
    def spatial_dark(self) -> list[EmvaLevel]:
        return self.select("spatial", True)

    def dark_for(self, level: EmvaLevel, kind: str | None = None) -> EmvaLevel:
        """The dark level recorded at the same exposure as ``level``."""
        kind = kind or level.kind
        for lv in self.select(kind, True):
            if math.isclose(lv.exposure_ns, level.exposure_ns, rel_tol=1e-9):
                return lv
        raise InputError(
            f"{self.path}:{level.line}: no {kind} dark level at exposure {level.exposure_ns:g} ns"
        )


@dataclass(frozen=True)
class Radiometry:
    """What the photon counts were converted from: per bright level (its ``line``) the kind
    (``"E"`` irradiance W/m^2 or ``"P"`` power W) and the reading, and the constants."""

    wavelength_nm: float
    pixel_area_um2: float
    detector_area_mm2: float | None
    readings: dict  # line -> (kind, value)

    def describe(self, line: int, exposure_s: float, photons: float) -> str:
        kind, value = self.readings[line]
        what = (f"irradiance E = {value:.4g} W/m^2" if kind == "E" else
                f"power-meter reading P = {value:.4g} W over {self.detector_area_mm2:g} mm^2 "
                f"(E = {value / (self.detector_area_mm2 * 1e-6):.4g} W/m^2)")
        return (f"{what}, pixel area A = {self.pixel_area_um2:g} um^2, wavelength {self.wavelength_nm:g} nm, "
                f"t_exp = {exposure_s * 1e3:.4g} ms -> mu_p = {photons:.4g} photons (EMVA 1288 4.0 Linear Eq. 3)")


def photons_from_reading(kind: str, value: float, exposure_s: float, wavelength_nm: float, pixel_area_um2: float,
                         detector_area_mm2: float | None = None) -> float:
    """Photons per pixel from an irradiance (``kind="E"``, W/m^2) or a power-meter reading
    (``"P"``, W over ``detector_area_mm2``): EMVA 1288 4.0 Linear Eq. (3), E = P / A_detector."""
    from ares.analysis.optics.spectral_qe import photons_per_pixel

    if kind == "E":
        return photons_per_pixel(value, 1.0, pixel_area_um2 * 1e-12, exposure_s, wavelength_nm)
    return photons_per_pixel(value, detector_area_mm2 * 1e-6, pixel_area_um2 * 1e-12, exposure_s, wavelength_nm)


MAX_DESCRIPTOR_BYTES = 16 << 20  # a descriptor is text: a few kB per hundred images


def _num(tok: str, where: str, what: str) -> float:
    try:
        v = float(tok.replace(",", "."))
    except ValueError:
        raise InputError(f"{where}: the {what} is not a number") from None  # (the file's text is never echoed)
    if not math.isfinite(v) or v < 0:
        raise InputError(f"{where}: the {what} must be a finite non-negative number")
    return v


def read_descriptor(path: str | Path, check_files: bool = True, wavelength_nm: float | None = None,
                    pixel_area_um2: float | None = None, detector_area_mm2: float | None = None) -> EmvaDescriptor:
    """Parse an EMVA 1288 descriptor file; image paths are resolved, optionally checked.
    ``wavelength_nm``, ``pixel_area_um2``, ``detector_area_mm2``: the constants of ``E=``/``P=``
    levels when the file has no ``w``/``a``/``m`` record (the file's own win)."""
    path = Path(path)
    text = read_regular(path, MAX_DESCRIPTOR_BYTES, "descriptor file").decode("utf-8", errors="replace")
    base = path.parent  # every image it references must lie below it (safefile.Confinement)
    confine = Confinement([base])
    version = ""
    fmt: tuple[int, int, int] | None = None
    levels: list[EmvaLevel] = []
    cur: dict | None = None
    consts: dict[str, tuple[float, int]] = {}  # w, a, m -> (value, line)
    readings: dict[int, tuple[str, float]] = {}

    def close(where_line: int) -> None:
        nonlocal cur
        if cur is None:
            return
        if len(cur["images"]) < 2:
            raise InputError(
                f"{path}:{cur['line']}: a level needs at least two images ('i PATH' records), "
                f"found {len(cur['images'])}"
            )
        levels.append(EmvaLevel(cur["dark"], cur["exp"], cur["photons"], tuple(cur["images"]), cur["line"]))
        cur = None

    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        where = f"{path}:{lineno}"
        tok = line.split()
        rec = tok[0]
        if rec == "i":
            if len(tok) < 2:
                raise InputError(f"{where}: 'i' record needs an image path")
            if cur is None:
                raise InputError(f"{where}: image record before any 'b' or 'd' level record")
            rel = line[1:].strip()
            p = base.joinpath(*PureWindowsPath(rel).parts) if "\\" in rel else base / rel
            p = confine(p, where)
            if check_files and not p.is_file():
                raise InputError(f"{where}: image file {p} not found")
            cur["images"].append(p)
            continue
        close(lineno)
        if rec == "v":
            if len(tok) != 2:
                raise InputError(f"{where}: expected 'v VERSION'")
            version = tok[1]
        elif rec == "n":
            if len(tok) != 4:
                raise InputError(f"{where}: expected 'n BITS WIDTH HEIGHT'")
            if fmt is not None:
                raise InputError(f"{where}: only one 'n' record is allowed")
            try:
                bits, w, h = (int(t) for t in tok[1:])
            except ValueError:
                raise InputError(f"{where}: 'n' record values must be integers") from None
            if not (1 <= bits <= 16) or w <= 0 or h <= 0:
                raise InputError(f"{where}: bits must be 1..16 and width/height positive")
            fmt = (bits, w, h)
        elif rec in ("w", "a", "m"):
            what = {"w": "wavelength (nm)", "a": "pixel area (um^2)", "m": "power-meter detector area (mm^2)"}[rec]
            if len(tok) != 2:
                raise InputError(f"{where}: expected '{rec} VALUE', the {what}")
            if rec in consts:
                raise InputError(f"{where}: only one '{rec}' record is allowed (the first is on line {consts[rec][1]})")
            v = _num(tok[1], where, what)
            if v <= 0:
                raise InputError(f"{where}: the {what} must be positive")
            consts[rec] = (v, lineno)
        elif rec == "b":
            if len(tok) != 3:
                raise InputError(f"{where}: expected 'b EXPOSURE_NS PHOTONS' (or E=W/m^2, P=W)")
            kind, _, val = tok[2].upper().partition("=") if "=" in tok[2] else ("", "", tok[2])
            if kind and kind not in ("E", "P"):
                raise InputError(f"{where}: '{tok[2][:20]}': a level's light is PHOTONS, E=IRRADIANCE (W/m^2) or "
                                 "P=POWER (W)")
            photons = _num(val, where, {"": "photon count", "E": "irradiance", "P": "power"}[kind])
            if kind:
                readings[lineno] = (kind, photons)
            cur = {"dark": False, "exp": _num(tok[1], where, "exposure"),
                   "photons": photons, "images": [], "line": lineno}
        elif rec == "d":
            if len(tok) != 2:
                raise InputError(f"{where}: expected 'd EXPOSURE_NS'")
            cur = {"dark": True, "exp": _num(tok[1], where, "exposure"), "photons": 0.0,
                   "images": [], "line": lineno}
        else:
            raise InputError(f"{where}: unknown record type (expected v, n, b, d or i); is this an EMVA 1288 "
                             "descriptor?")
    close(0)
    if fmt is None:
        raise InputError(f"{path}: missing 'n BITS WIDTH HEIGHT' record")
    if not levels:
        raise InputError(f"{path}: no 'b' or 'd' levels")
    radiometry = None
    if readings:
        levels, radiometry = _convert(path, levels, readings, consts, wavelength_nm, pixel_area_um2,
                                      detector_area_mm2)
    seen: set[tuple] = set()
    for lv in levels:
        key = (lv.kind, lv.dark, lv.exposure_ns, lv.photons)
        if key in seen:
            raise InputError(f"{path}:{lv.line}: duplicate {lv.kind} level at exposure {lv.exposure_ns:g} ns")
        seen.add(key)
    return EmvaDescriptor(path, version, fmt[0], fmt[1], fmt[2], tuple(levels), _attribution(text, path), radiometry,
                          consts["a"][0] if "a" in consts else None, consts["w"][0] if "w" in consts else None)


def _convert(path, levels, readings, consts, wavelength_nm, pixel_area_um2, detector_area_mm2):
    """The ``E=``/``P=`` levels with their photons per pixel (Eq. 3), and the ``Radiometry``."""
    import dataclasses

    def const(rec, given, what, opt):
        if rec in consts:
            return consts[rec][0]
        if given:
            return float(given)
        first = min(ln for ln, (k, _) in readings.items() if rec != "m" or k == "P")
        raise InputError(f"{path}:{first}: converting this reading to photons needs the {what}: a '{rec} VALUE' "
                         f"record or {opt}")

    lam = const("w", wavelength_nm, "wavelength (nm)", "--wavelength-nm")
    area = const("a", pixel_area_um2, "pixel area (um^2)", "--pixel-size-um")
    det = const("m", detector_area_mm2, "power-meter detector area (mm^2)", "--detector-area-mm2") \
        if any(k == "P" for k, _ in readings.values()) else consts.get("m", (detector_area_mm2, 0))[0]
    out = []
    for lv in levels:
        if lv.line in readings:
            kind, v = readings[lv.line]
            lv = dataclasses.replace(lv, photons=photons_from_reading(kind, v, lv.exposure_s, lam, area, det))
        out.append(lv)
    return out, Radiometry(lam, area, det, dict(readings))


def _attribution(text: str, path: Path) -> str:
    """The Basler notice for the EMVA 1288 reference set (its descriptor's header names
    Basler), else the descriptor's path."""
    if "Basler" in text[:2000]:
        from ares.analysis.emva.release3 import ATTRIBUTION

        return ATTRIBUTION
    return f"recorded data: {path}"


def read_checked(desc: EmvaDescriptor, p: Path) -> np.ndarray:
    """One image of the set, checked against the ``n`` record: its size, an image type
    that can hold the declared bits (an 8-bit image in a 12-bit set has lost bits or is
    not this set's), and no value above them."""
    a = read_image(p)
    if a.shape != (desc.height, desc.width):
        raise InputError(
            f"{p}: image is {a.shape[1]}x{a.shape[0]}, descriptor {desc.path} declares "
            f"{desc.width}x{desc.height}"
        )
    if 8 * a.dtype.itemsize < desc.bits:
        raise InputError(f"{p}: the image has {8 * a.dtype.itemsize} bits a pixel, too few for the {desc.bits}-bit "
                         f"data descriptor {desc.path} declares (such data are stored as 16-bit images)")
    if int(a.max()) >= (1 << desc.bits):
        raise InputError(f"{p}: pixel value {int(a.max())} exceeds the declared {desc.bits} bits")
    return a


def iter_level(desc: EmvaDescriptor, level: EmvaLevel):
    """The images of one level one at a time, each checked against the ``n`` record."""
    for p in level.images:
        yield read_checked(desc, p)


def load_level(desc: EmvaDescriptor, level: EmvaLevel) -> np.ndarray:
    """All images of one level as a (n, rows, cols) uint16 stack, checked against ``n``."""
    return np.stack(list(iter_level(desc, level))).astype(np.uint16, copy=False)


class EmvaReplaySource:
    """Replays a descriptor's images as a ``FrameSource``.

    ``set_level(i)`` (or the ``levels`` given at construction) chooses what ``grab``
    delivers; frames cycle through the level's images and carry ``exposure_s``,
    ``photons``, ``dark`` and ``level`` in ``Frame.meta``.
    """

    def __init__(self, descriptor: EmvaDescriptor | str | Path, levels: Sequence[EmvaLevel] | None = None):
        self.descriptor = descriptor if isinstance(descriptor, EmvaDescriptor) else read_descriptor(descriptor)
        d = self.descriptor
        self.name = f"emva:{d.path.name}"
        self.shape = (d.height, d.width)
        self.bit_depth = d.bits
        self.levels = list(levels) if levels is not None else list(d.levels)
        self._level = 0
        self._pos = 0
        self._count = 0

    def set_level(self, index: int) -> None:
        if not 0 <= index < len(self.levels):
            raise InputError(f"{self.name}: level {index} out of range 0..{len(self.levels) - 1}")
        self._level, self._pos = index, 0

    @property
    def level(self) -> EmvaLevel:
        return self.levels[self._level]

    def grab(self, n: int) -> Iterator[Frame]:
        lv = self.level
        for _ in range(n):
            p = lv.images[self._pos % len(lv.images)]
            self._pos += 1
            data = read_checked(self.descriptor, p)
            meta = {"exposure_s": lv.exposure_s, "photons": lv.photons, "dark": lv.dark,
                    "level": self._level, "path": str(p)}
            yield Frame(data=data, index=self._count, timestamp=float(self._count), meta=meta)
            self._count += 1

    def select(self, exposure_s: float | None = None, photons: float = 0.0, kind: str | None = None) -> EmvaLevel:
        """Choose the level recorded at ``exposure_s`` (default: the current one) and
        ``photons`` per pixel (0 = dark); raises ``InputError`` when none was recorded."""
        exp_ns = self.level.exposure_ns if exposure_s is None else exposure_s * 1e9
        for i, lv in enumerate(self.levels):
            if (kind is None or lv.kind == kind) and math.isclose(lv.exposure_ns, exp_ns, rel_tol=1e-6) \
                    and (lv.dark if photons == 0 else math.isclose(lv.photons, photons, rel_tol=1e-6)):
                self.set_level(i)
                return lv
        what = "dark" if photons == 0 else f"{photons:g} photons/pixel"
        raise InputError(f"{self.descriptor.path}: no recorded {what} level at exposure {exp_ns:g} ns")

    def close(self) -> None:
        pass


class EmvaReplayLight:
    """``LightSource`` for a replay bench: the level is photons per pixel, and setting it
    selects the recorded level at the source's current exposure (0 = the dark level)."""

    def __init__(self, source: EmvaReplaySource):
        self.name = f"{source.name}:light"
        self.source = source
        self._level = 0.0

    def set_level(self, level: float) -> None:
        self.source.select(None, float(level))
        self._level = float(level)

    def get_level(self) -> float:
        return self._level

    def settle(self, cancel=None) -> None:
        pass
