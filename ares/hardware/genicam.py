"""GenICam cameras (USB3 Vision, GigE Vision, any GenTL producer) through harvesters.

The system XML's ``<genicam cti= device=>`` names the GenTL producer file (``genicam:NAME``
is a producer shipped inside the ``genicam`` package, e.g. its simulated camera
``genicam:viky.cti``) and the camera (id, serial number or index). ``<set node value>``
writes features at open (pixel format, size); ``<feature field node scale>`` makes a
feature a register field of the system (``feature_map``), so scans set exposure or gain
on a camera exactly as on an I2C sensor: through ``FeatureFile`` (a ``RegisterFile`` that
passes the feature's own typed value: floats and negative values intact, checked against
the node's type, limits and increment first -- ``ares.hardware.genicam_features``).

Buffers become uint8/uint16 frames by harvesters' own pixel-format conversion (its PFNC
table expands every packed layout: Mono10p/12p, the GigE Vision Mono12Packed, BayerRG12p
...): any monochrome or raw Bayer format (one value per pixel) is taken; a Bayer format must
name the mosaic the system XML's ``<cfa>`` declares; colour formats (RGB8 ..., already
demosaiced) are refused. Packed bytes a producer hands over unexpanded are unpacked here
(Mono10p/12p/14p, ``ares.hardware.pixels``). A gap in the buffer's frame id is a dropped
frame (``FrameLost``); a fetch that times out is a ``HardwareError``; both name the camera.
A camera that fails (``DeviceGone``) is opened again by ``reconnect`` (a scan's recovery).
The fetch timeout is the XML's ``timeout_ms`` or the frame time (exposure + readout +
margin, ``set_frame_time``) when longer.
"""

from __future__ import annotations

import os
import time

import numpy as np

from ares.errors import DeviceGone, FrameError, FrameLost, HardwareError, InputError
from ares.hardware.interfaces import Frame
from ares.hardware.pixels import FORMATS, unpack
from ares.hardware.registers import Field, RegisterMap

_PACKED = {"Mono10p": "mono10p", "Mono12p": "mono12p", "Mono14p": "mono14p"}  # when harvesters did not expand
_BAYER = ("RG", "GR", "GB", "BG")  # BayerRG12 -> RGGB (the <cfa pattern>)
_IDENTITY = (("vendor", "DeviceVendorName"), ("model", "DeviceModelName"), ("serial", "DeviceSerialNumber"),
             ("firmware", "DeviceFirmwareVersion"))  # SFNC names


def feature_map(cfg) -> RegisterMap:
    """The camera's ``<feature>`` elements as register fields (address = position; the raw
    value is the feature's value in its own unit, physical = scale x raw)."""
    fields = tuple(Field(f.field, i, 0, 31, scale=f.scale, unit=f.unit, minimum=f.min, maximum=f.max,
                         description=f"GenICam feature {f.node}", signed=True) for i, f in enumerate(cfg.features))
    return RegisterMap(address_bits=16, value_bits=32, endian="big", fields=fields)


def producer_path(cti: str) -> str:
    """``genicam:NAME`` -> the file inside the installed genicam package; else the path."""
    if cti.startswith("genicam:"):
        try:
            import genicam
        except ImportError:
            raise DeviceGone(f"GenTL producer {cti}: the genicam package is not installed") from None
        return os.path.join(os.path.dirname(genicam.__file__), cti.split(":", 1)[1])
    return os.path.expanduser(cti)


class GenICamCamera:
    """One open camera: the harvesters image acquirer and its node map."""

    def __init__(self, cfg):
        self.cfg = cfg
        self.name = f"GenICam camera '{cfg.name}'"
        self._open()

    def _open(self) -> None:
        cfg = self.cfg
        path = producer_path(cfg.cti)
        if not os.path.isfile(path):
            raise DeviceGone(f"{self.name}: GenTL producer {path} does not exist")
        try:
            from harvesters.core import Harvester
        except ImportError:
            raise DeviceGone(f"{self.name}: the harvesters package is not installed") from None
        self.h = Harvester()
        try:
            self.h.add_file(path)
            self.h.update()
            self.ia = self.h.create(self._select())
        except (DeviceGone, InputError):
            self.h.reset()
            raise
        except Exception as exc:  # harvesters/GenTL raise their own types
            self.h.reset()
            raise DeviceGone(f"{self.name}: cannot open the camera through {path} ({exc})") from None
        self._configure()

    @classmethod
    def attach(cls, cfg, ia) -> "GenICamCamera":
        """A camera around an image acquirer already opened (an emulated one: no GenTL producer)."""
        cam = cls.__new__(cls)
        cam.cfg, cam.name, cam.ia, cam.h = cfg, f"GenICam camera '{cfg.name}'", ia, None
        cam._configure()
        return cam

    def _configure(self) -> None:
        """The ``<set>`` features, then the trigger, strobe and chunk time stamp as declared (SFNC)."""
        cfg = self.cfg
        self.nodes = self.ia.remote_device.node_map
        for node, value in cfg.sets:
            self.write(node, value)
        t = getattr(cfg, "trigger", None)
        if t is not None:
            self.write("TriggerSelector", "FrameStart")
            self.write("TriggerMode", "Off" if t.mode == "free_run" else "On")
            if t.mode != "free_run":
                self.write("TriggerSource", "Software" if t.mode == "software" else f"Line{t.line}")
                if t.mode == "hardware":
                    self.write("TriggerActivation", "RisingEdge" if t.edge == "rising" else "FallingEdge")
            if t.strobe == "exposure":  # the output line high while exposing
                self.write("LineSelector", f"Line{t.strobe_line}")
                self.write("LineMode", "Output")
                self.write("LineSource", "ExposureActive")
        if getattr(cfg, "chunk_timestamp", False):
            self.write("ChunkModeActive", "true")
            self.write("ChunkSelector", "Timestamp")
            self.write("ChunkEnable", "true")

    def _select(self):
        infos = self.h.device_info_list
        if not infos:
            raise DeviceGone(f"{self.name}: the GenTL producer lists no camera")
        d = self.cfg.device
        for i, info in enumerate(infos):
            if d in (getattr(info, "id_", None), getattr(info, "serial_number", None)):
                return i
        if d.isdigit() and int(d) < len(infos):
            return int(d)
        known = ", ".join(str(getattr(i, "id_", "?")) for i in infos)
        raise DeviceGone(f"{self.name}: no camera '{d}' (the producer lists: {known})")

    def node(self, name: str):
        try:
            return getattr(self.nodes, name)
        except Exception:
            raise InputError(f"{self.name}: has no GenICam feature '{name}'") from None

    def write(self, name: str, value) -> None:
        """Set feature ``name``, checked first against its type and limits
        (``ares.hardware.genicam_features.coerce``)."""
        from ares.hardware.genicam_features import coerce

        n = self.node(name)
        v = coerce(self.name, name, n, value)
        try:
            n.value = v
        except Exception as exc:
            raise HardwareError(f"{self.name}: cannot set feature {name} to {value} ({exc})") from None

    def reconnect(self) -> None:
        """Open the camera again after it was unplugged (``DeviceGone`` while it is away): the
        producer lists its cameras again, the same one is selected and its ``<set>`` features
        written again (a replugged camera has lost them)."""
        try:
            self.close()
        except Exception:  # noqa: BLE001 -- a camera that is gone may not close cleanly
            pass
        self._open()

    def close(self) -> None:
        try:
            self.ia.destroy()
        finally:
            if self.h is not None:
                self.h.reset()


class FeatureBus:
    """``RegisterBus`` over the camera's features: address i = the i-th ``<feature>``."""

    def __init__(self, camera: GenICamCamera):
        self.camera = camera
        self.name = camera.name
        self.nodes = [f.node for f in camera.cfg.features]

    def _node(self, address: int) -> str:
        if not 0 <= address < len(self.nodes):
            raise InputError(f"{self.name}: no feature at address {address}")
        return self.nodes[address]

    def read(self, address: int) -> int:
        node = self._node(address)
        try:
            v = int(round(float(self.camera.node(node).value)))
        except InputError:
            raise
        except Exception as exc:
            raise HardwareError(f"{self.name}: cannot read feature {node} ({exc})") from None
        if not -(1 << 31) <= v < 1 << 31:
            raise HardwareError(f"{self.name}: feature {node} reads {v}, beyond what a 32-bit <feature> field holds")
        return v & 0xFFFFFFFF  # (the fields are signed: two's complement, -3 dB reads back as -3)

    def write(self, address: int, value: int) -> None:
        value = int(value)
        self.camera.write(self._node(address), value - (1 << 32) if value >= 1 << 31 else value)

    def reconnect(self) -> None:
        self.camera.reconnect()

    def close(self) -> None:
        self.camera.close()


class GenICamFrameSource:
    def __init__(self, camera: GenICamCamera, shape: tuple[int, int], bit_depth: int, cfa: str = "mono"):
        self.camera = camera
        self.name = camera.name
        self.shape, self.bit_depth, self.cfa = tuple(shape), int(bit_depth), cfa
        self.count = 0
        self.last_id: int | None = None
        self.dropped = self.timeouts = 0
        self.frame_time_s = 0.0  # exposure + readout + margin of the current settings (ares.scan.apply)

    def set_frame_time(self, seconds: float) -> None:
        """The current frame time: a 20 s exposure is not a 2 s fetch timeout."""
        self.frame_time_s = max(0.0, float(seconds))

    @property
    def timeout_ms(self) -> int:
        base = max(int(self.camera.cfg.timeout_ms), int(round(1000 * self.frame_time_s)))
        t = getattr(self.camera.cfg, "trigger", None)
        if t is not None and t.mode == "hardware":  # waiting for the line's edge too
            return base + int(t.timeout_ms or self.camera.cfg.timeout_ms)
        return base

    def _convert(self, comp) -> np.ndarray:
        fmt = str(comp.data_format)
        h, w = int(comp.height), int(comp.width)
        if (h, w) != self.shape:
            raise FrameError(f"{self.name}: delivers {w}x{h} but the system XML declares "
                             f"{self.shape[1]}x{self.shape[0]}")
        bayer = fmt[5:7] if fmt.startswith("Bayer") and fmt[5:7] in _BAYER else None
        if bayer is not None:
            mosaic = {"RG": "RGGB", "GR": "GRBG", "GB": "GBRG", "BG": "BGGR"}[bayer]
            if mosaic != self.cfa:
                raise FrameError(f"{self.name}: pixel format {fmt} is a {mosaic} mosaic but the system XML declares "
                                 f"<cfa pattern='{self.cfa}'>")
        elif not fmt.startswith("Mono"):
            raise FrameError(f"{self.name}: pixel format {fmt} is not raw sensor data (set PixelFormat to a Mono or "
                             "Bayer format with <set node='PixelFormat'>)")
        raw = np.asarray(comp.data)
        if raw.dtype == np.uint8 and raw.size != h * w and fmt in _PACKED:  # packed bytes, not expanded
            return unpack(raw, FORMATS[_PACKED[fmt]], self.shape)
        if raw.size != h * w or raw.dtype.kind not in "ui" or raw.dtype.itemsize > 2:
            raise FrameError(f"{self.name}: pixel format {fmt} arrived as {raw.size} {raw.dtype} values for "
                             f"{w}x{h} pixels (harvesters could not expand it)")
        return np.array(raw, dtype=np.uint8 if raw.dtype.itemsize == 1 else np.uint16, copy=True).reshape(self.shape)

    def reconnect(self) -> None:
        """Open the camera again (``GenICamCamera.reconnect``); the frame ids start afresh."""
        self.camera.reconnect()
        self.last_id = None

    def link_counters(self) -> dict:
        """The link statistics since open (``ares.hardware.link_stats``)."""
        return {"frames": self.count, "dropped_frames": self.dropped, "timeouts": self.timeouts}

    def identity(self) -> dict:
        """Vendor, model, serial number and firmware as the camera's node map gives them."""
        out = {"interface": "GenICam"}
        for key, node in _IDENTITY:
            try:
                v = getattr(self.camera.nodes, node).value
            except Exception:  # noqa: BLE001 -- a camera without the SFNC node: not given
                continue
            if v not in (None, ""):
                out[key] = str(v)
        return out

    def grab(self, n: int):
        ia = self.camera.ia
        timeout = self.timeout_ms / 1000.0
        try:
            ia.start()
        except Exception as exc:
            raise DeviceGone(f"{self.name}: cannot start acquisition ({exc})") from None
        t = getattr(self.camera.cfg, "trigger", None)
        chunk = getattr(self.camera.cfg, "chunk_timestamp", False)
        try:
            for _ in range(n):
                if t is not None and t.mode == "software":  # one frame per software trigger
                    self.camera.node("TriggerSoftware").execute()
                try:
                    buf = ia.fetch(timeout=timeout)
                except Exception as exc:
                    if "timeout" in type(exc).__name__.lower():  # a frame late: lost, re-grabbed where the
                        self.timeouts += 1  # scan says so (on_loss="regrab", <suspend device>)
                        why = f"; no edge on hardware trigger line {t.line}?" if t and t.mode == "hardware" else ""
                        raise FrameLost(f"{self.name}: no frame within {self.timeout_ms} ms "
                                        f"(timeout{why}) at frame {self.count}", "timeout") from None
                    raise DeviceGone(f"{self.name}: acquisition failed at frame {self.count} ({exc})") from None
                try:
                    fid = getattr(buf.module, "frame_id", None)
                    stamp = _chunk_seconds(self.camera) if chunk else _device_seconds(buf)  # the camera's clock
                    data = self._convert(buf.payload.components[0])
                finally:
                    buf.queue()
                if fid is not None and self.last_id is not None and fid != self.last_id + 1:
                    gap = fid - self.last_id - 1
                    self.last_id = fid
                    if gap > 0:
                        self.dropped += gap
                        raise FrameLost(f"{self.name}: {gap} frame(s) dropped before frame {self.count} "
                                        f"(frame id jumped to {fid})", "dropped", gap)
                self.last_id = fid
                top = int(data.max())
                if top >= (1 << self.bit_depth):
                    raise FrameError(f"{self.name}: frame {self.count} has code {top} above the "
                                     f"{self.bit_depth}-bit range of <adc bits>")
                meta = {"frame_id": fid} if stamp is None else {"frame_id": fid, "device_timestamp_s": stamp}
                frame = Frame(data, self.count, time.time(), meta)
                self.count += 1
                yield frame
        finally:
            try:
                ia.stop()
            except Exception:  # stopping a camera that failed must not hide why
                pass
            self.last_id = None

    def close(self) -> None:
        pass  # the FeatureBus owns the camera (Bench.close closes it once)


def build_genicam_bench(system):
    """A ``Bench`` for a ``<genicam>`` system: the camera's features as register fields,
    its buffers as frames; serial instruments as declared."""
    from ares.hardware.interfaces import Bench
    from ares.hardware.genicam_features import FeatureFile
    from ares.hardware.serial_instruments import SerialChamber, SerialLightSource

    cam = GenICamCamera(system.genicam)
    opened = [cam]
    try:
        regs = FeatureFile(system.registers, FeatureBus(cam))
        frames = GenICamFrameSource(cam, (system.sensor.rows, system.sensor.cols), system.sensor.adc_bits,
                                    system.sensor.cfa)
        light = SerialLightSource.open(system.light_source) if system.light_source else None
        opened.append(light)
        chamber = SerialChamber.open(system.chamber) if system.chamber else None
    except BaseException:
        for d in opened:
            if d is not None:
                d.close()
        raise
    return Bench(regs, frames, light, chamber, {"system": system.name, "camera": system.genicam.name,
                                                "producer": producer_path(system.genicam.cti)})


def _chunk_seconds(camera) -> float | None:
    """The frame's time stamp from its chunk data (``ChunkTimestamp``, ns), None without one."""
    try:
        ns = int(camera.nodes.ChunkTimestamp.value)
        return ns * 1e-9 if ns >= 0 else None
    except Exception:  # noqa: BLE001 -- no chunk in this buffer: host time only
        return None


def _device_seconds(buf) -> float | None:
    """The buffer's device time stamp in seconds (GenTL ``timestamp_ns``), None without one."""
    try:
        ns = getattr(buf, "timestamp_ns", None)
        return None if ns is None or int(ns) <= 0 else int(ns) * 1e-9
    except Exception:  # noqa: BLE001 -- a producer that cannot say: host time only
        return None
