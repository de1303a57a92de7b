"""GenICam cameras (USB3 Vision, GigE Vision, any GenTL producer) through harvesters.

The system XML's ``<genicam cti= device=>`` names the GenTL producer file (``genicam:NAME``
is a producer shipped inside the ``genicam`` package, e.g. its simulated camera
``genicam:viky.cti``) and the camera (id, serial number or index). ``<set node value>``
writes features at open (pixel format, size); ``<feature field node scale>`` makes a
feature a register field of the system (``feature_map``), so scans set exposure or gain
on a camera exactly as on an I2C sensor: through ``FeatureFile`` (a ``RegisterFile`` that
passes the feature's own typed value: floats and negative values intact, checked against
the node's type, limits and increment first -- ``ares.hardware.genicam_features``).

Buffers are converted to uint8/uint16 frames: Mono8/10/12/14/16 and the packed
Mono10p/12p/14p (``ares.hardware.pixels``). A gap in the buffer's frame id is a dropped
frame (``FrameLost``); a fetch that times out is a ``HardwareError``; both name the camera.
"""

from __future__ import annotations

import os
import time

import numpy as np

from ares.errors import DeviceGone, FrameError, FrameLost, HardwareError, InputError
from ares.hardware.interfaces import Frame
from ares.hardware.pixels import FORMATS, unpack
from ares.hardware.registers import Field, RegisterMap

_UNPACKED = {"Mono8": np.uint8, "Mono10": np.uint16, "Mono12": np.uint16, "Mono14": np.uint16, "Mono16": np.uint16}
_PACKED = {"Mono10p": "mono10p", "Mono12p": "mono12p", "Mono14p": "mono14p"}


def feature_map(cfg) -> RegisterMap:
    """The camera's ``<feature>`` elements as register fields (address = position; the raw
    value is the feature's value in its own unit, physical = scale x raw)."""
    fields = tuple(Field(f.field, i, 0, 31, scale=f.scale, unit=f.unit, minimum=f.min, maximum=f.max,
                         description=f"GenICam feature {f.node}") for i, f in enumerate(cfg.features))
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
        self.nodes = self.ia.remote_device.node_map
        for node, value in cfg.sets:
            self.write(node, value)

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

    def close(self) -> None:
        try:
            self.ia.destroy()
        finally:
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
        if v < 0:  # a register field's raw value is unsigned
            raise HardwareError(f"{self.name}: feature {node} reads {v}, below 0, which a <feature> field cannot hold")
        return v

    def write(self, address: int, value: int) -> None:
        self.camera.write(self._node(address), value)

    def close(self) -> None:
        self.camera.close()


class GenICamFrameSource:
    def __init__(self, camera: GenICamCamera, shape: tuple[int, int], bit_depth: int):
        self.camera = camera
        self.name = camera.name
        self.shape, self.bit_depth = tuple(shape), int(bit_depth)
        self.count = 0
        self.last_id: int | None = None
        self.dropped = 0

    def _convert(self, comp) -> np.ndarray:
        fmt = str(comp.data_format)
        h, w = int(comp.height), int(comp.width)
        if (h, w) != self.shape:
            raise FrameError(f"{self.name}: delivers {w}x{h} but the system XML declares "
                             f"{self.shape[1]}x{self.shape[0]}")
        if fmt in _UNPACKED:
            return np.array(comp.data, dtype=_UNPACKED[fmt], copy=True).reshape(self.shape)
        if fmt in _PACKED:
            raw = np.asarray(comp.data)
            if raw.dtype != np.uint8:  # harvesters already unpacked it
                return np.array(raw, dtype=np.uint16).reshape(self.shape)
            return unpack(raw, FORMATS[_PACKED[fmt]], self.shape)
        raise FrameError(f"{self.name}: pixel format {fmt} is not supported (set PixelFormat to one of "
                         f"{', '.join(list(_UNPACKED) + list(_PACKED))} with <set node='PixelFormat'>)")

    def grab(self, n: int):
        ia = self.camera.ia
        timeout = self.camera.cfg.timeout_ms / 1000.0
        try:
            ia.start()
        except Exception as exc:
            raise DeviceGone(f"{self.name}: cannot start acquisition ({exc})") from None
        try:
            for _ in range(n):
                try:
                    buf = ia.fetch(timeout=timeout)
                except Exception as exc:
                    if "timeout" in type(exc).__name__.lower():
                        raise HardwareError(f"{self.name}: no frame within {self.camera.cfg.timeout_ms} ms "
                                            f"(timeout) at frame {self.count}") from None
                    raise DeviceGone(f"{self.name}: acquisition failed at frame {self.count} ({exc})") from None
                try:
                    fid = getattr(buf.module, "frame_id", None)
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
                frame = Frame(data, self.count, time.time(), {"frame_id": fid})
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
        frames = GenICamFrameSource(cam, (system.sensor.rows, system.sensor.cols), system.sensor.adc_bits)
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
