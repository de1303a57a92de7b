"""An emulated USB frame grabber behind a pyusb backend (``usb.backend.IBackend``).

``usb.core.find(..., backend=EmulatedUsbBackend([grabber]))`` (``usb_backend``) finds it like a real device;
``UsbFrameSource`` then drives it through pyusb's public API only: descriptors, string
descriptors (the serial number), ``set_configuration``, control transfers and bulk reads.

The device side (``EmulatedGrabber``) streams a frame source's frames in the declared wire
format: the ``ares32`` header (with payload CRC), the pixel format packed as declared and
the ADC channels in the declared wire order.

USB packet rules, as a host controller enforces them (``bulk_read``): the device sends
packets of ``max_packet`` bytes (its endpoint descriptor's wMaxPacketSize); a transfer
ends with a short packet, or with a zero-length packet (ZLP) when its length is a multiple
of ``max_packet``. A host read of N bytes ends when N bytes came or at a short packet; a
packet larger than the room left in the host's buffer is an overflow (libusb's
``[Errno 75] Overflow``: the packet is lost). With ``header_packet="own"`` the header (with
any junk before it) is a transfer of its own and the payload another; with ``"inline"``
(FX3-style firmware) header and payload are one transfer. A frame that takes longer than
the host's read timeout (``latency``: exposure + readout of the current settings) is a
timeout, decided in model time (nothing sleeps). With a ``start`` control whose value is ``frames`` the
device renders that many frames when it is armed (the frame source reads its registers
then, as the simulated bench does); without one it renders a frame whenever the host
reads and nothing is pending.

Faults (``--sim-fault`` keys, N = the device's 0-based frame counter):
``usb_drop_at`` (frame N rendered, never sent: a counter gap), ``usb_corrupt_at`` (payload
bytes altered after the CRC), ``usb_short_at`` (half the payload, then the transfer
ends), ``usb_garbage_at`` (junk bytes before frame N: the host resynchronises),
``usb_timeout_at`` (no data: the read times out), ``usb_disconnect_at`` (unplugged; with
``usb_reconnect_after_polls`` = M it is found again at the M-th search).

Transient faults (issue 49): ``usb_late_at`` (frame N comes ``usb_late_ms`` late, default 1200:
past the host's read timeout it is a timeout, and the frame arrives after it), ``usb_stall_at``
(the endpoint halts at frame N: every bulk read is EPIPE until the host clears the halt;
what the FIFO held is lost), ``usb_gone_s`` = S (with ``usb_disconnect_at``: unplugged for S
seconds of the bench's clock -- emulated time -- then found again), ``usb_reconnect_packet``
= P (found again with wMaxPacketSize P: the host must read the descriptor anew).

``usb_trigger_missing_at`` = N: in hardware-trigger mode the pulse generator skips the edge for
frame N (the host's read times out; the frame comes at the next edge). ``usb_pipeline_frames``
= K: a sensor that keeps exposing after a stop -- K frames exposed at the settings of that moment
wait in the device and come first at the next start (what a settings change must discard).

``usb_frame_in_flight`` = 1: a streaming rolling-shutter sensor -- the next frame starts, and
latches its held and double-buffered registers, as soon as one is read out; it is read out
at the next host read with what its registers hold then. The first frame after a register
change was latched before it: it carries none of a held change, and an unheld, unbuffered
register written since (an analog gain) with the old latched ones (a multi-register exposure
written in its own hold) -- a frame half old, half new. ``usb_frame_in_flight`` = 2: the same
with vertical blanking -- the next frame starts after it, which is later than a host's read-back
right after a frame and sooner than its next register writes (``SensorRegisters.owe_start``): a
read-back after the frame in flight still finds the old values latched.

``exposed_with``: device frame counter -> the settings the simulator rendered that frame with
(``exposure_s``, ``analog_gain``, ``black_level_dn``, ``photon_flux``: the light over the frame's
own exposure window, a frame in flight's included) and ``exposure_start_s``
(the ``ares40`` time stamp, on the bench's clock): the device's truth (the latest 20000 frames).
"""

from __future__ import annotations

import errno
import itertools
import time
from collections import deque
from types import SimpleNamespace

import numpy as np

from ares.errors import DeviceGone, FrameError
from ares.hardware import frame_header as fh
from ares.hardware.emulators.usb_backend import usb_error
from ares.hardware.pixels import pack, pixel_format, to_wire_order

FAULTS = ("usb_drop_at", "usb_corrupt_at", "usb_short_at", "usb_garbage_at", "usb_timeout_at",
          "usb_disconnect_at", "usb_reconnect_after_polls", "usb_pipeline_frames", "usb_late_at", "usb_late_ms",
          "usb_stall_at", "usb_gone_s", "usb_reconnect_packet", "usb_trigger_missing_at", "usb_frame_in_flight")
TRUTH = ("exposure_s", "analog_gain", "black_level_dn", "photon_flux")  # what ``exposed_with`` keeps of a frame
EXPOSED_KEPT = 20000  # frames ``exposed_with`` remembers


class EmulatedGrabber:
    """The device: descriptors, control requests and the bulk-IN byte stream."""

    def __init__(self, frames, cfg, *, channels: int = 1, interleave: str = "none", faults: dict | None = None,
                 serial: str = "ARES-EMU-0001", crc: bool = True, embed=None, max_packet: int = 512,
                 zlp: bool = True, latency=None):
        self.frames, self.cfg = frames, cfg
        self.fmt = pixel_format(cfg.format)
        self.channels, self.interleave = channels, interleave
        self.faults = {k: int(v) for k, v in (faults or {}).items() if k in FAULTS}
        self.serial, self.crc = serial, crc
        self.embed = embed  # (row, first register, register bus, value bits): registers in an image row
        self.counter = 0  # frames produced (sent or dropped)
        self.connected = True
        self.polls = 0
        self._gen = None  # armed frames
        self._queued: list = []  # frames exposed after the last stop (usb_pipeline_frames)
        self._owed = 0  # frames dropped while armed: rendered again after the armed ones
        self._out: deque = deque()  # packets sent and not yet read by the host
        self.max_packet, self.zlp = int(max_packet), bool(zlp)
        self.header_packet = getattr(cfg, "header_packet", "own")
        self.latency = latency  # callable: seconds a frame takes at the current settings (None: no wait)
        self.overflows = 0
        self.configuration = 0
        start = [c for c in cfg.controls if c.when == "start"]
        self._start = start[0] if start and start[0].value == "frames" else None
        self.requests: list[tuple] = []  # control requests received (tests look at them)
        self.clock = getattr(frames, "clock", None)  # the bench's clock (emulated time: usb_gone_s)
        self.halted = False  # the endpoint stalled (usb_stall_at) until the host clears the halt
        self._gone_at = None
        self.handles_closed = 0  # host handles disposed (a reconnect must let go of the old one)
        self.on_frame_start = None  # callable: a frame starts (a double-buffered sensor latches its registers)
        # trigger and strobe, as the firmware keeps them: free run at power-up, set by the host's requests
        self.trigger_mode, self.trigger_input, self.falling = 0, 0, False  # 0 free run, 1 software, 2 hardware
        self.software_triggers = 0  # software trigger requests not yet answered with a frame
        self.line = TriggerLine()  # the hardware trigger input: a frame per edge, none without
        self.strobe, self.strobe_output = False, 1
        self.strobes: list[tuple[float, float]] = []  # (start, width s) of each strobe pulse driven
        self.head_size = fh.SIZES.get(cfg.header, 32)
        self.timestamp_hz = float(getattr(cfg, "timestamp_hz", 1e9))
        self._started = 0.0  # the device clock at the current frame's exposure start
        self.exposed_with: dict[int, dict] = {}  # device frame counter -> the settings it was rendered with
        self._in_flight, self._ahead_start = False, None  # (usb_frame_in_flight) the next frame has started
        # (latching its registers) at that device clock
        self.blanking = None  # (usb_frame_in_flight=2) the sensor registers: owe_start(), start_if_owed()

    # ------------------------------------------------------------ descriptors
    def device_descriptor(self, address: int):
        return SimpleNamespace(
            bLength=18, bDescriptorType=1, bcdUSB=0x0200, bDeviceClass=0xFF, bDeviceSubClass=0, bDeviceProtocol=0,
            bMaxPacketSize0=64, idVendor=self.cfg.vid, idProduct=self.cfg.pid, bcdDevice=0x0100, iManufacturer=1,
            iProduct=2, iSerialNumber=3, bNumConfigurations=1, address=address, bus=1, port_number=address,
            port_numbers=(address,), speed=3)

    def config_descriptor(self):
        return SimpleNamespace(bLength=9, bDescriptorType=2, wTotalLength=25, bNumInterfaces=1, bConfigurationValue=1,
                               iConfiguration=0, bmAttributes=0x80, bMaxPower=250, extra_descriptors=[])

    def interface_descriptor(self):
        return SimpleNamespace(bLength=9, bDescriptorType=4, bInterfaceNumber=self.cfg.interface, bAlternateSetting=0,
                               bNumEndpoints=1, bInterfaceClass=0xFF, bInterfaceSubClass=0, bInterfaceProtocol=0,
                               iInterface=0, extra_descriptors=[])

    def endpoint_descriptor(self):
        return SimpleNamespace(bLength=7, bDescriptorType=5, bEndpointAddress=self.cfg.endpoint, bmAttributes=2,
                               wMaxPacketSize=self.max_packet, bInterval=0, bRefresh=0, bSynchAddress=0, extra_descriptors=[])

    def _string(self, index: int) -> bytes:
        if index == 0:
            body = (0x0409).to_bytes(2, "little")  # language: English (US)
        else:
            body = {1: "ARES", 2: "ARES emulated grabber", 3: self.serial}.get(index, "").encode("utf-16-le")
        return bytes([2 + len(body), 3]) + body

    # ------------------------------------------------------------ requests
    def _gone(self):
        if not self.connected:
            raise usb_error(errno.ENODEV, "No such device (it may have been disconnected)")

    def control(self, request_type: int, request: int, value: int, index: int, data) -> bytes | int:
        self._gone()
        if request_type == 0x80 and request == 6 and value >> 8 == 3:  # GET_DESCRIPTOR (string)
            return self._string(value & 0xFF)
        self.requests.append((request_type, request, value, index, bytes(data or b"")))
        for c in self.cfg.controls:
            if (c.request_type, c.request) == (request_type, request):
                if c.when == "trigger_mode":
                    self.trigger_mode, self.trigger_input = int(value), int(index) & 0xFF
                    self.falling, self.software_triggers = bool(index & 0x100), 0
                elif c.when == "strobe":
                    self.strobe, self.strobe_output = bool(value), int(index)
                elif c.when == "trigger":
                    self.software_triggers += 1
                elif c.when == "start" and self._start is not None:
                    queued, self._queued = self._queued[:int(value)], []
                    fresh = int(value) - len(queued)
                    if self.faults.get("usb_frame_in_flight"):  # each frame read out with its own registers
                        fresh_frames = (self._grab_one() for _ in range(fresh))
                    else:
                        fresh_frames = self.frames.grab(fresh) if fresh else ()
                    self._gen = itertools.chain(queued, fresh_frames)
                    self._out, self._owed = deque(), 0
                elif c.when == "stop":
                    self._gen, self._out = None, deque()
                    k = self.faults.get("usb_pipeline_frames", 0)
                    if k and not self._queued:  # exposed now, at the settings of now
                        self._queued = list(self.frames.grab(k))
        return len(data or b"") if not request_type & 0x80 else bytes(max(1, len(data or b"")))

    def _send(self, transfer: bytes) -> None:
        """One transfer as packets: full ones, then a short one (a ZLP when it ends on a
        packet boundary and the device sends them)."""
        m = self.max_packet
        for k in range(0, len(transfer), m):
            self._out.append(transfer[k:k + m])
        if self.zlp and len(transfer) % m == 0:
            self._out.append(b"")

    def _next_transfer(self, timeout_ms: int | None = None) -> None:
        n = self.counter
        if self.halted:
            raise usb_error(errno.EPIPE, "Pipe error (endpoint halted)")
        if n == self.faults.get("usb_disconnect_at"):
            self.connected = False
            self.faults.pop("usb_disconnect_at")
            self._gone_at = self.clock.now() if self.clock is not None else None
            self._gone()
        if n == self.faults.get("usb_stall_at"):
            self.faults.pop("usb_stall_at")
            self.halted = True
            raise usb_error(errno.EPIPE, "Pipe error (endpoint halted)")
        if n == self.faults.get("usb_timeout_at"):
            self.faults.pop("usb_timeout_at")
            time.sleep(self.cfg.timeout_ms / 1000.0)
            raise usb_error(errno.ETIMEDOUT, "Operation timed out", timeout=True)
        self._frame_starts()  # (latching held registers: the exposure this frame takes is the latched one)
        if self.latency is not None and timeout_ms and 1000 * self.latency() > timeout_ms:
            raise usb_error(errno.ETIMEDOUT, "Operation timed out", timeout=True)  # the frame is still exposing
        if self.trigger_mode == 1 and not self.software_triggers:  # waiting for the host's trigger
            raise usb_error(errno.ETIMEDOUT, "Operation timed out (no software trigger)", timeout=True)
        if self.trigger_mode == 2 and n == self.faults.get("usb_trigger_missing_at"):  # the generator skips one
            self.faults.pop("usb_trigger_missing_at")
            raise usb_error(errno.ETIMEDOUT, "Operation timed out (no edge on the trigger line)", timeout=True)
        if self.trigger_mode == 2 and not self.line.take():  # waiting for an edge on the trigger input
            raise usb_error(errno.ETIMEDOUT, "Operation timed out (no edge on the trigger line)", timeout=True)
        if self.trigger_mode == 1:
            self.software_triggers -= 1
        self._started = self.clock.now() if self.clock is not None else float(self.counter)
        try:
            frame = self._render()
        except DeviceGone:  # the sensor behind the wire is gone: the host sees the device vanish (ENODEV),
            self.connected, self._gen, self._out = False, None, deque()  # never the sensor's own exception
            self._gone_at = self.clock.now() if self.clock is not None else None
            self._gone()
        except FrameError:  # a frame the sensor could not read out: its header, then the transfer ends
            self.counter += 1  # (as far as it came: less than a packet)
            rows, cols = self.frames.shape
            head = fh.Header(n, cols, rows, self.fmt.code, self.fmt.payload_bytes(rows * cols)).encode(self.head_size)
            cut = bytes(self.max_packet // 2)
            if self.header_packet == "inline":
                self._send(head + cut)
            else:
                self._send(head)
                self._send(cut)
            return
        self.counter += 1
        meta = getattr(frame, "meta", None) or {}
        self.exposed_with[n] = {k: meta[k] for k in TRUTH if k in meta}
        self.exposed_with[n]["exposure_start_s"] = self._started
        if len(self.exposed_with) > EXPOSED_KEPT:  # (a long run on the wires: the latest frames')
            del self.exposed_with[next(iter(self.exposed_with))]
        if n == self.faults.get("usb_drop_at"):  # rendered, lost: the next frame shows the gap
            self.faults.pop("usb_drop_at")
            self._owed += 1
            return self._next_transfer(timeout_ms)
        if self.strobe:  # high while the frame exposes
            self.strobes.append((self._started, float(getattr(frame, "meta", {}).get("exposure_s", 0.0))))
        img = np.asarray(frame.data)
        if self.embed is not None:
            img = self._embed(img)
        wire = to_wire_order(img, self.cfg.wire_order, self.channels, self.interleave)
        payload = bytearray(pack(wire, self.fmt))
        crc = fh.payload_crc(payload) if self.crc else 0
        if n == self.faults.get("usb_corrupt_at"):
            self.faults.pop("usb_corrupt_at")
            payload[len(payload) // 3:len(payload) // 3 + 64] = b"\xff" * 64
        rows, cols = wire.shape
        head = fh.Header(n, cols, rows, self.fmt.code, len(payload), fh.FLAG_CRC if self.crc else 0, crc,
                         round(self._started * self.timestamp_hz)).encode(self.head_size)
        if n == self.faults.get("usb_short_at"):
            self.faults.pop("usb_short_at")
            payload = payload[:len(payload) // 2]
        junk = b""
        if n == self.faults.get("usb_garbage_at"):
            self.faults.pop("usb_garbage_at")
            junk = bytes(range(7, 250)) + fh.SYNC[:2]
        if self.header_packet == "inline":
            self._send(junk + head + bytes(payload))
        else:
            self._send(junk + head)
            self._send(bytes(payload))
        if n == self.faults.get("usb_late_at"):  # the frame is on its way, after the host stopped waiting
            self.faults.pop("usb_late_at")
            late = self.faults.get("usb_late_ms", 1200) + (1000 * self.latency() if self.latency else 0)
            if timeout_ms and late > timeout_ms:
                raise usb_error(errno.ETIMEDOUT, "Operation timed out (frame late)", timeout=True)

    def _exposure_start(self, frame) -> float:
        """When ``frame`` started exposing (ahead: at the last read-out; the simulator's: its stamp)."""
        if self._ahead_start is not None:
            return self._ahead_start
        if self.clock is not None and getattr(self.frames, "clock", None) is self.clock:
            return float(frame.timestamp)
        return self._started

    def _frame_starts(self) -> None:  # a frame starts: the registers it is exposed with latch
        ahead = int(self.faults.get("usb_frame_in_flight", 0))
        if self.on_frame_start is not None and not (ahead and self._in_flight):
            self.on_frame_start()  # (streaming ahead: it started, latched, when the frame before was read out)
            self._ahead_start = None
        elif ahead == 2 and self.blanking is not None:
            self.blanking.start_if_owed()  # (after the blanking: before it is read out, at the latest)

    def _render(self):
        """The sensor's next frame: armed ones first (a grab with a start control), else one now."""
        ahead = int(self.faults.get("usb_frame_in_flight", 0))
        frame, blank = self._read_out(), self.blanking if ahead == 2 else None
        self._started = self._exposure_start(frame)
        if ahead and self.on_frame_start is not None:  # the next frame starts as this one is read out
            if blank is not None:
                blank.owe_start()  # (or after the blanking)
            else:
                self.on_frame_start()
            self._in_flight = True
            self._ahead_start = self.clock.now() if self.clock is not None else float(self.counter + 1)
        return frame

    def _read_out(self):
        if self._start is None:
            return self._grab_one()
        if self._gen is None:
            raise usb_error(errno.ETIMEDOUT, "Operation timed out (not armed)", timeout=True)
        try:
            return next(self._gen)
        except StopIteration:
            if not self._owed:
                self._gen = None
                raise usb_error(errno.ETIMEDOUT, "Operation timed out (no more frames armed)", timeout=True) from None
            self._owed -= 1  # a dropped frame still costs an exposure: one more to deliver N
            return self._grab_one()

    def _grab_one(self):
        """The sensor's next frame. One streamed ahead (``usb_frame_in_flight``) started exposing as
        the frame before was read out: the simulator renders it with the light over its own exposure
        from then (part old, part new at a change), as its time stamp says."""
        if self._ahead_start is not None and self.faults.get("usb_frame_in_flight") and self.clock is not None:
            return next(iter(self.frames.grab(1, started=self._ahead_start)))
        return next(iter(self.frames.grab(1)))

    def _embed(self, img: np.ndarray) -> np.ndarray:
        """A sensor without I2C read: its registers, one byte per pixel, in an image row."""
        row, start, regs, bits = self.embed
        nb = bits // 8
        out = bytearray()
        for a in range(start, start + img.shape[1] // nb):
            try:
                out += int(regs.read(a)).to_bytes(nb, "big")
            except Exception:  # beyond the address space: zeros
                out += bytes(nb)
        img = img.copy()
        img[row, :len(out)] = np.frombuffer(bytes(out), np.uint8)
        return img

    def bulk_read(self, endpoint: int, size: int, timeout_ms: int | None = None) -> bytes:
        """One host read of up to ``size`` bytes under the packet rules (module docstring)."""
        self._gone()
        if endpoint != self.cfg.endpoint:
            raise usb_error(errno.EPIPE, f"endpoint 0x{endpoint:02x} does not exist")
        got = bytearray()
        while len(got) < size:
            if not self._out:
                self._next_transfer(timeout_ms)
            packet = self._out.popleft()
            if len(packet) > size - len(got):
                self.overflows += 1
                raise usb_error(errno.EOVERFLOW, "Overflow")
            got += packet
            if len(packet) < self.max_packet:  # short packet or ZLP: the transfer ended
                break
        return bytes(got)

    def clear_halt(self, endpoint: int) -> None:
        """The host clears the endpoint's halt: reads work again; what the FIFO held is lost."""
        self._gone()
        self.halted = False
        self._out = deque()

    def present(self) -> bool:
        """Seen by a search: a disconnected device comes back at the M-th search after it left
        (``usb_reconnect_after_polls``), or ``usb_gone_s`` seconds of the bench's clock after."""
        if not self.connected:
            self.polls += 1
            back = self.faults.get("usb_reconnect_after_polls")
            gone_s = self.faults.get("usb_gone_s")
            if gone_s is not None and self.clock is not None and self._gone_at is not None:
                if self.clock.now() - self._gone_at >= gone_s:
                    back = 0
            if back is not None and self.polls >= back:
                self.connected = True
                self._gen, self._out = None, deque()
                if "usb_reconnect_packet" in self.faults:  # enumerated again at another speed
                    self.max_packet = int(self.faults["usb_reconnect_packet"])
        return self.connected


class TriggerLine:
    """The grabber's hardware trigger input: ``fire(n)`` sends n edges (a light source's sync
    output, a test); each starts one frame in hardware-trigger mode, none arrives without. With
    ``generator`` a pulse generator drives it at the frame rate: an edge whenever the sensor is
    ready for one (the wire bench wires one to a system declaring a hardware trigger)."""

    def __init__(self, generator: bool = False):
        self.edges = 0  # edges not yet answered with a frame
        self.fired = 0
        self.generator = generator

    def fire(self, n: int = 1) -> None:
        self.edges += int(n)
        self.fired += int(n)

    def take(self) -> bool:
        if self.edges <= 0 and self.generator:
            self.fire()
        if self.edges <= 0:
            return False
        self.edges -= 1
        return True
