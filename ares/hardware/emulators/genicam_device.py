"""An emulated GenICam camera: an image acquirer (``start``/``stop``/``fetch``) with a node map
of SFNC features, as harvesters hands a real one to ``ares.hardware.genicam`` -- written from
what a camera does, not from the host code:

* ``TriggerSelector=FrameStart``, ``TriggerMode`` Off (free run: a buffer per fetch) or On with
  ``TriggerSource`` ``Software`` (a frame per ``TriggerSoftware`` execution) or ``LineN`` (a
  frame per edge on input line N, ``lines[N].fire()``); a fetch with no frame started times out
  (``TimeoutException``, as harvesters raises it).
* ``LineSelector=LineN``, ``LineMode=Output``, ``LineSource=ExposureActive``: a strobe on line N
  while each frame exposes (``strobes``: start, width s).
* ``ChunkModeActive``, ``ChunkSelector=Timestamp``, ``ChunkEnable``: each buffer's chunk data
  carries the device clock at exposure start (``ChunkTimestamp``, ns); the buffer's own
  ``timestamp_ns`` is when its transfer completed (exposure and readout later).
* ``ExposureTime`` (us) is the sensor's exposure (the simulated bench's ``exposure`` register).

Frames come from a frame source (the simulator's); the device clock is its bench clock.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ares.hardware.emulators.usb_device import TriggerLine


class TimeoutException(Exception):
    """No buffer within the fetch timeout (the name harvesters' exception carries)."""


class _Node:
    def __init__(self, get, put, symbolics=None, lo=None, hi=None):
        self._get, self._put = get, put
        if symbolics is not None:
            self.symbolics = tuple(symbolics)
        if lo is not None:
            self.min, self.max = lo, hi

    @property
    def value(self):
        return self._get()

    @value.setter
    def value(self, v):
        if hasattr(self, "symbolics") and v not in self.symbolics:
            raise ValueError(f"{v!r} is not an entry")
        self._put(v)


class _Command:
    def __init__(self, fn):
        self.execute = fn


class EmulatedCamera:
    """The camera (its node map is ``remote_device.node_map``) and its image acquirer."""

    LINES = 4

    def __init__(self, frames, registers=None, *, readout_s: float = 0.001, clock=None):
        self.frames, self.registers, self.readout_s = frames, registers, float(readout_s)
        self.clock = clock if clock is not None else getattr(frames, "clock", None)
        self.state = {"TriggerSelector": "FrameStart", "TriggerMode": "Off", "TriggerSource": "Software",
                      "TriggerActivation": "RisingEdge", "LineSelector": "Line0", "ChunkModeActive": False,
                      "ChunkSelector": "Timestamp", "ChunkTimestamp": 0, "PixelFormat": "Mono16"}
        self.line_mode = {f"Line{k}": "Input" for k in range(self.LINES)}
        self.line_source = {f"Line{k}": "Off" for k in range(self.LINES)}
        self.chunk_enable = {"Timestamp": False, "FrameID": False}
        self.lines = [TriggerLine() for _ in range(self.LINES)]  # the inputs: fire() = an edge
        self.software_triggers = 0
        self.strobes: list[tuple[str, float, float]] = []  # (line, start s, width s)
        self.acquiring, self.frame_id = False, 0
        nodes = {k: self._plain(k, e) for k, e in (
            ("TriggerSelector", ("FrameStart",)), ("TriggerMode", ("Off", "On")),
            ("TriggerSource", ("Software",) + tuple(f"Line{k}" for k in range(self.LINES))),
            ("TriggerActivation", ("RisingEdge", "FallingEdge")),
            ("LineSelector", tuple(f"Line{k}" for k in range(self.LINES))), ("ChunkModeActive", None),
            ("ChunkSelector", ("Timestamp", "FrameID")), ("ChunkTimestamp", None), ("PixelFormat", ("Mono16",)))}
        sel = lambda: self.state["LineSelector"]  # noqa: E731
        nodes["LineMode"] = _Node(lambda: self.line_mode[sel()], lambda v: self.line_mode.__setitem__(sel(), v),
                                  ("Input", "Output"))
        nodes["LineSource"] = _Node(lambda: self.line_source[sel()], lambda v: self.line_source.__setitem__(sel(), v),
                                    ("Off", "ExposureActive", "FrameActive"))
        csel = lambda: self.state["ChunkSelector"]  # noqa: E731
        nodes["ChunkEnable"] = _Node(lambda: self.chunk_enable[csel()],
                                     lambda v: self.chunk_enable.__setitem__(csel(), bool(v)))
        nodes["ExposureTime"] = _Node(self._exposure_us, self._set_exposure_us, lo=1.0, hi=1e8)
        nodes["TriggerSoftware"] = _Command(self._software_trigger)
        for name, value in (("DeviceVendorName", "ARES"), ("DeviceModelName", "EMULATED-GEV"),
                            ("DeviceSerialNumber", "EMU-0001")):
            nodes[name] = SimpleNamespace(value=value)
        self.remote_device = SimpleNamespace(node_map=SimpleNamespace(**nodes))

    def _plain(self, key, entries):
        return _Node(lambda: self.state[key], lambda v: self.state.__setitem__(key, v), entries)

    def _exposure_us(self) -> float:
        return 1e6 * self.registers.get("exposure") if self.registers is not None else 10000.0

    def _set_exposure_us(self, us) -> None:
        if self.registers is not None:
            self.registers.set("exposure", float(us) * 1e-6)

    def _software_trigger(self) -> None:
        if self.state["TriggerMode"] == "On" and self.state["TriggerSource"] == "Software":
            self.software_triggers += 1  # (ignored when not waiting for one, as a camera does)

    # ------------------------------------------------------------ the image acquirer
    def start(self) -> None:
        self.acquiring = True

    def stop(self) -> None:
        self.acquiring = False

    def destroy(self) -> None:
        self.acquiring = False

    def _started(self) -> bool:
        """Whether a frame starts now (free run; a software trigger; an edge on the trigger line)."""
        if self.state["TriggerMode"] == "Off":
            return True
        src = self.state["TriggerSource"]
        if src == "Software":
            if self.software_triggers:
                self.software_triggers -= 1
                return True
            return False
        return self.lines[int(src[4:])].take()

    def fetch(self, timeout: float = 0.0):
        if not self.acquiring or not self._started():
            raise TimeoutException(f"no buffer within {timeout:g} s")
        t0 = self.clock.now() if self.clock is not None else float(self.frame_id)
        frame = next(iter(self.frames.grab(1)))
        exposure = self._exposure_us() * 1e-6
        for line, src in self.line_source.items():
            if self.line_mode[line] == "Output" and src == "ExposureActive":
                self.strobes.append((line, t0, exposure))
        if self.state["ChunkModeActive"] and self.chunk_enable["Timestamp"]:
            self.state["ChunkTimestamp"] = int(round(t0 * 1e9))
        self.frame_id += 1
        data = np.ascontiguousarray(frame.data, dtype=np.uint16)
        comp = SimpleNamespace(data_format="Mono16", height=data.shape[0], width=data.shape[1], data=data.ravel())
        done = int(round((t0 + exposure + self.readout_s) * 1e9))
        return SimpleNamespace(module=SimpleNamespace(frame_id=self.frame_id), timestamp_ns=done,
                               payload=SimpleNamespace(components=[comp]), queue=lambda: None)
