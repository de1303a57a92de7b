"""Frames from a USB bulk-endpoint frame grabber (pyusb): a ``FrameSource``.

The system XML's ``<usb_grabber>`` declares everything on the wire: VID/PID (and
``serial`` to pick one of several), the control transfers to send at open, before and
after each grab (``value="frames"`` = the number of frames), the IN endpoint, the read
size (``chunk_bytes``), the frame header, the pixel format (``ares.hardware.pixels``) and
the order the ADC channels arrive in.

With ``header="ares32"`` (``ares.hardware.frame_header``) every frame is checked: sync
word (searched for again after garbage: resynchronisation), size and format against the
XML, the payload CRC when the device sends one, and the frame counter -- a gap is a
dropped frame. Frames that do not arrive whole raise ``FrameLost`` (dropped, corrupt,
short: a bulk read that ends early ends the transfer); the scan re-grabs the stage or
fails, as it declares. Transient faults are frames lost too: a read that times out (a frame
late past the timeout) is ``FrameLost`` kind "timeout", a stalled endpoint (EPIPE) is
cleared (``clear_halt``) and is ``FrameLost`` kind "stall"; either way the grab is stopped,
what the device still holds is flushed before the next start and the frame counter is
followed afresh, so a re-grab starts clean (``<frames on_loss="regrab">`` or a ``<suspend>``
device condition re-acquire the stage). A device that vanishes is ``DeviceGone``; its
reconnect disposes of the old handle and reads the endpoint's packet size anew. A watchdog (``watchdog_ms`` for a whole frame) ends a
grab whose data trickle in without ever completing a frame. Every sentence names the
grabber.

USB packet rules: every bulk read asks for a whole number of the endpoint's
wMaxPacketSize (from its descriptor), so a device packet never overflows the host's buffer
(libusb's ``[Errno 75] Overflow``); bytes read past what a step needed are carried to the
next. ``header_packet="own"`` (the header is a short packet of its own): the header read
asks for one packet. ``"inline"`` (FX3-style: header and payload in one transfer): the
first read asks for the whole frame and the header is parsed out of its first packet. A
zero-length packet ending the previous transfer is skipped.
"""

from __future__ import annotations

import array
import errno
import time

import numpy as np

from ares.errors import DeviceGone, FrameError, FrameLost, HardwareError
from ares.hardware import frame_header as fh
from ares.hardware.interfaces import Frame
from ares.hardware.pixels import from_wire_order, pixel_format, unpack
from ares.hardware.trigger import usb_request


def _usb():
    import usb.core

    return usb.core


class UsbFrameSource:
    def __init__(self, device, cfg, shape: tuple[int, int], bit_depth: int, channels: int = 1,
                 interleave: str = "none"):
        self.dev, self.cfg = device, cfg
        self.name = f"USB frame grabber '{cfg.name}' ({cfg.vid:04x}:{cfg.pid:04x})"
        self.shape, self.bit_depth = tuple(shape), int(bit_depth)
        self.channels, self.interleave = int(channels), interleave
        self.fmt = pixel_format(cfg.format)
        self.payload = self.fmt.payload_bytes(shape[0] * shape[1])
        self.head = fh.SIZES.get(cfg.header, int(cfg.header_bytes))
        self.trigger = getattr(cfg, "trigger", None)  # <trigger>: None/free_run streams, else one frame per trigger
        self.frame_bytes = self.head + self.payload
        self.watchdog_s = (cfg.watchdog_ms or 4 * cfg.timeout_ms) / 1000.0
        self.max_packet = _max_packet(device, cfg)
        self.inline = getattr(cfg, "header_packet", "own") == "inline"
        self._chunk = array.array("B", bytes(_whole_packets(min(int(cfg.chunk_bytes), self.frame_bytes),
                                                            self.max_packet)))
        self._bufs = {len(self._chunk): self._chunk}
        self._buf = np.empty(self.payload, np.uint8)
        self._ended = False  # the last read ended its transfer (short packet)
        self._carry = bytearray()  # bytes read past the end of a frame (a stream without transfer framing)
        self.count = 0  # frames delivered
        self.frame_time_s = 0.0  # exposure + readout + margin of the current settings (ares.scan.apply)
        self.counter_mode = counter_mode(cfg)
        # continuous: the device counts from 0 after open, so a lost first frame is a gap too
        self.last_counter: int | None = -1 if self.counter_mode == "continuous" else None
        self._first = True  # the next frame is a grab's first (a device reset shows there)
        self.dropped = self.corrupt = self.short = self.resyncs = self.skipped_bytes = 0
        self.counter_resets = 0  # a continuous counter that went back between grabs (device restarted)
        # link statistics (the run record: ares.hardware.link_stats): bulk reads, bytes, reads
        # that ended their transfer with a short packet / a zero-length packet, timeouts, overflows
        self.transfers = self.bytes = self.short_packets = self.zlps = self.timeouts = self.overflows = 0
        self._lost_sync = False  # searching for a sync word (counted once per search)
        self.stalls = 0  # endpoint halts cleared (EPIPE -> clear_halt)
        self._dirty = False  # a transient fault left bytes in the device: flush before the next start
        self.after_frame: list = []  # called as each frame arrives (double-buffered registers read back)

    # ------------------------------------------------------------ open / control
    @classmethod
    def open(cls, cfg, shape, bit_depth, backend=None, channels: int = 1, interleave: str = "none"):
        core = _usb()
        try:
            found = list(core.find(find_all=True, idVendor=cfg.vid, idProduct=cfg.pid, backend=backend))
        except core.NoBackendError:
            raise DeviceGone(f"USB frame grabber '{cfg.name}': no USB backend (libusb) is installed") from None
        if cfg.serial is not None:
            found = [d for d in found if _serial_of(d) == cfg.serial]
        if not found:
            which = f" with serial number {cfg.serial}" if cfg.serial is not None else ""
            raise DeviceGone(f"USB frame grabber '{cfg.name}' ({cfg.vid:04x}:{cfg.pid:04x}){which} is not connected")
        dev = found[0]
        try:
            dev.set_configuration()
        except core.USBError as exc:
            raise DeviceGone(f"USB frame grabber '{cfg.name}': cannot configure the device ({exc})") from None
        src = cls(dev, cfg, shape, bit_depth, channels, interleave)
        src._backend = backend
        src._control("open", 0)
        src._control("trigger_mode", 0)  # the device's trigger mode and strobe, as declared (again after a replug)
        src._control("strobe", 0)
        return src

    def reconnect(self) -> None:
        """Find the grabber by VID/PID (and serial) again and configure it (``DeviceGone`` while
        away): the old handle is disposed of, and the endpoint's packet size read anew (a
        device may come back at another speed: 512-byte high-speed, 1024-byte super-speed)."""
        again = type(self).open(self.cfg, self.shape, self.bit_depth, getattr(self, "_backend", None),
                                self.channels, self.interleave)
        old, self.dev = self.dev, again.dev
        _dispose(old)
        self.max_packet = again.max_packet
        self._chunk = again._chunk
        self._bufs = {len(self._chunk): self._chunk}
        self.last_counter = None
        self._carry.clear()
        self._ended = self._dirty = False

    def _control(self, when: str, frames: int) -> None:
        core = _usb()
        for c in self.cfg.controls:
            if c.when != when:
                continue
            value, index = frames if c.value == "frames" else c.value, c.index
            if when in ("trigger_mode", "strobe"):
                value, index = usb_request(self.trigger, when)
            try:
                if c.request_type & 0x80:  # device-to-host: read (and discard) what it answers
                    self.dev.ctrl_transfer(c.request_type, c.request, value & 0xFFFF, index, max(1, len(c.data)),
                                           self.cfg.timeout_ms)
                else:
                    self.dev.ctrl_transfer(c.request_type, c.request, value & 0xFFFF, index, c.data or None,
                                           self.cfg.timeout_ms)
            except core.USBTimeoutError:
                raise HardwareError(f"{self.name}: no answer to the '{when}' control request 0x{c.request:02x} "
                                    f"within {self.cfg.timeout_ms} ms (timeout)") from None
            except core.USBError as exc:
                raise self._usb_error(exc, f"the '{when}' control request 0x{c.request:02x}") from None

    def _usb_error(self, exc, what: str) -> HardwareError:
        if getattr(exc, "errno", None) in (errno.ENODEV, 19) or "No such device" in str(exc):
            return DeviceGone(f"{self.name}: device disconnected during {what}")
        if getattr(exc, "errno", None) == errno.EOVERFLOW:
            return HardwareError(f"{self.name}: the device sent a packet larger than the read during {what} "
                                 f"(overflow; reads are whole {self.max_packet}-byte packets: check wMaxPacketSize)")
        if getattr(exc, "errno", None) == errno.EPIPE:
            return HardwareError(f"{self.name}: endpoint stalled during {what} ({exc})")
        return HardwareError(f"{self.name}: USB error during {what} ({exc})")

    # ------------------------------------------------------------ timing
    @property
    def timeout_ms(self) -> int:
        """One bulk read's timeout: the XML's ``timeout_ms``, or longer when a frame takes
        longer (exposure + readout + margin, from ``set_frame_time``)."""
        base = max(int(self.cfg.timeout_ms), int(round(1000 * self.frame_time_s)))
        if self.trigger is not None and self.trigger.mode == "hardware":  # waiting for the line's edge too
            return base + int(self.trigger.timeout_ms or self.cfg.timeout_ms)
        return base

    def set_frame_time(self, seconds: float) -> None:
        """The current frame time (exposure + ``<timing readout_s>`` + ``margin_s``): a 20 s
        exposure is not a 2 s timeout."""
        self.frame_time_s = max(0.0, float(seconds))

    def flush(self) -> None:
        """Drop what the device and the host still hold (frames exposed at earlier settings):
        the bytes carried over, then reads with a short timeout until none come (at most two
        frames' worth: a free-running sensor never runs dry)."""
        core = _usb()
        self._carry.clear()
        left = 2 * self.frame_bytes
        while left > 0:
            try:
                n = self._bulk(self._chunk, 10)
            except core.USBTimeoutError:  # nothing left: how a flush ends (not counted as a timeout)
                return
            except core.USBError as exc:
                raise self._usb_error(exc, "the flush before a stack") from None
            if not n:
                return
            left -= n

    def _bulk(self, buf, timeout: int) -> int:
        """One bulk read into ``buf``, counted for the link statistics."""
        try:
            n = self.dev.read(self.cfg.endpoint, buf, timeout=timeout)
        except _usb().USBError as exc:
            if getattr(exc, "errno", None) == errno.EOVERFLOW:
                self.overflows += 1
            raise
        self.transfers += 1
        self.bytes += n
        if n < len(buf):
            if n:
                self.short_packets += 1
            else:
                self.zlps += 1
        return n

    def _transient(self, message: str, kind: str) -> FrameLost:
        """A transient fault: the frame is lost, the stream is followed afresh (the counter is
        resynchronised, carried bytes dropped, the device flushed before the next start)."""
        self._carry.clear()
        self.last_counter = None
        self._dirty = True
        return FrameLost(message, kind)

    # ------------------------------------------------------------ bytes
    def _read(self, want: int, deadline: float) -> memoryview:
        """One bulk read of at least ``want`` bytes rounded up to whole packets (more may
        come: the caller carries them; fewer than asked = the transfer ended)."""
        core = _usb()
        if time.monotonic() > deadline:
            raise HardwareError(f"{self.name}: watchdog: frame {self.count} not complete within "
                                f"{self.watchdog_s * 1000:.0f} ms (watchdog_ms)")
        want = min(_whole_packets(want, self.max_packet), len(self._chunk))
        buf = self._bufs.get(want)
        if buf is None:  # header, payload, chunk and remainder sizes: a handful, kept
            buf = self._bufs[want] = array.array("B", bytes(want))
        try:
            n = self._bulk(buf, self.timeout_ms)
        except core.USBTimeoutError:
            self.timeouts += 1
            t = self.trigger
            why = (f"; no edge on hardware trigger line {t.line}?" if t is not None and t.mode == "hardware" else "")
            raise self._transient(f"{self.name}: no data on endpoint 0x{self.cfg.endpoint:02x} within "
                                  f"{self.timeout_ms} ms (timeout{why}) at frame {self.count}", "timeout") from None
        except core.USBError as exc:
            if getattr(exc, "errno", None) == errno.EPIPE:  # the endpoint halted: clear it, then re-grab
                try:
                    self.dev.clear_halt(self.cfg.endpoint)
                except core.USBError as again:
                    raise self._usb_error(again, f"clearing the halted endpoint at frame {self.count}") from None
                self.stalls += 1
                raise self._transient(f"{self.name}: endpoint 0x{self.cfg.endpoint:02x} stalled at frame {self.count} "
                                      "(EPIPE; the halt was cleared)", "stall") from None
            raise self._usb_error(exc, f"frame {self.count}") from None
        self._ended = n < want  # a short packet (or ZLP): this transfer is over
        return memoryview(buf)[:n]

    def _header(self, deadline: float):
        """The next valid header (searching past garbage), or None with header='none'."""
        if self.cfg.header not in fh.SIZES:
            if self.head:
                self._payload_from(self.head, deadline, skip=True)
            return None
        while True:
            while len(self._carry) < self.head:
                need = (self.frame_bytes if self.inline else self.head) - len(self._carry)
                self._carry += self._read(need, deadline)
            try:
                h = fh.decode(self._carry, self.head)
                del self._carry[:self.head]
                return h
            except fh.BadHeader:
                p = self._carry.find(fh.SYNC, 1)
                drop = p if p >= 0 else len(self._carry) - (len(fh.SYNC) - 1)
                self.skipped_bytes += drop
                del self._carry[:drop]
                if not self._lost_sync:
                    self._lost_sync = True
                    self.resyncs += 1

    def _payload_from(self, size: int, deadline: float, skip: bool = False) -> int:
        """Fill ``self._buf[:size]`` (or discard ``size`` bytes); returns the bytes received
        before the transfer ended (== size when whole)."""
        got = 0
        # inline: the carried bytes came in the header's transfer; if it ended, so did the frame
        ended = self.inline and self._ended and bool(self._carry)
        if self._carry:
            k = min(len(self._carry), size)
            if not skip:
                self._buf[:k] = np.frombuffer(self._carry, np.uint8, count=k)
            del self._carry[:k]
            got = k
        zlp_skipped = got > 0
        while got < size and not ended:
            want = min(size - got, len(self._chunk))
            mv = self._read(want, deadline)
            n = len(mv)
            if n == 0 and not zlp_skipped:  # the ZLP that ended the header's transfer
                zlp_skipped = True
                continue
            take = min(n, size - got)
            if not skip:
                self._buf[got:got + take] = np.frombuffer(mv[:take], np.uint8)
            if n > take:  # the next frame's first bytes (a stream without transfer framing)
                self._carry += mv[take:]
            got += take
            if n < want:
                break
        return got

    # ------------------------------------------------------------ frames
    def _frame(self) -> Frame:
        deadline = time.monotonic() + self.watchdog_s + self.frame_time_s
        h = self._header(deadline)
        self._lost_sync = False
        if h is not None:
            want = (self.shape[1], self.shape[0], self.fmt.code, self.payload)
            if (h.width, h.height, h.format_code, h.payload) != want:
                self._payload_from(h.payload, deadline, skip=True)
                raise FrameError(f"{self.name}: device counter {h.counter} sends {h.width}x{h.height}, format "
                                 f"0x{h.format_code:08x}, {h.payload} bytes but the system XML declares "
                                 f"{want[0]}x{want[1]} {self.fmt.name} ({self.payload} bytes)")
        got = self._payload_from(self.payload, deadline)
        where = f"frame {self.count}" + (f" (device counter {h.counter})" if h is not None else "")
        if got < self.payload:
            self.short += 1
            if h is not None:  # the frame was sent: the re-grab must not count it as dropped
                self.last_counter = h.counter
            raise FrameLost(f"{self.name}: {where} arrived short ({got + self.head} of {self.frame_bytes} bytes)",
                            "short")
        if h is not None:
            if h.flags & fh.FLAG_CRC and fh.payload_crc(self._buf) != h.crc:
                self.corrupt += 1
                self.last_counter = h.counter
                raise FrameLost(f"{self.name}: {where} is corrupt (payload CRC mismatch)", "corrupt")
            gap = 0 if self.last_counter is None else (h.counter - self.last_counter - 1) & 0xFFFFFFFF
            last, first, self._first = self.last_counter, self._first, False
            self.last_counter = h.counter
            if gap >= 1 << 31:  # the counter went back
                if first:  # between grabs: the device restarted its count; follow it
                    self.counter_resets += 1
                    gap = 0
                else:
                    self.corrupt += 1
                    raise FrameLost(f"{self.name}: the frame counter went back from {last} to {h.counter} at {where} "
                                    "(the device restarted mid-grab)", "corrupt")
            if gap:
                self.dropped += gap
                raise FrameLost(f"{self.name}: {gap} frame(s) dropped before {where} (frame counter jumped "
                                f"from {(h.counter - gap - 1) & 0xFFFFFFFF} to {h.counter})", "dropped", gap)
        data = unpack(self._buf, self.fmt, self.shape)
        if self.fmt.container == 1:
            data = data.astype(np.uint8, copy=True)
        data = from_wire_order(data, self.cfg.wire_order, self.channels, self.interleave)
        top = int(data.max())
        if top >= (1 << self.bit_depth):
            self.corrupt += 1
            raise FrameLost(f"{self.name}: {where} is corrupt (code {top} above the {self.bit_depth}-bit range)",
                            "corrupt")
        meta = {"counter": h.counter} if h is not None else {}
        if h is not None and h.timestamp is not None:  # the device's clock at exposure start (ares40)
            meta["device_timestamp_s"] = h.timestamp / float(getattr(self.cfg, "timestamp_hz", 1e9))
        return Frame(data, self.count, time.time(), meta)

    def grab(self, n: int):
        if self.counter_mode == "free_running":
            self.last_counter = None  # frames between grabs are not read, not lost: checked within the grab
        elif self.counter_mode == "per_grab":
            self.last_counter = -1  # the device counts from 0 at every start
        self._first = True
        if self._dirty:  # after a transient fault: what the device still held is stale
            self._dirty = False
            self.flush()
        self._control("start", n)
        ok = False
        try:
            for _ in range(n):
                if self.trigger is not None and self.trigger.mode == "software":
                    self._control("trigger", 0)  # one frame per software trigger
                frame = self._frame()
                self.count += 1
                for hook in self.after_frame:  # a frame boundary has passed since the last register writes
                    hook()
                yield frame
            ok = True
        finally:
            try:
                self._control("stop", 0)
            except HardwareError:
                if ok:
                    raise  # otherwise the error in flight is the one to report

    def stats(self) -> dict:
        """Counters for the run record: frames, dropped, corrupt, short, resyncs, skipped bytes
        (and counter resets, when a continuous counter restarted between grabs)."""
        out = {"frames": self.count, "dropped": self.dropped, "corrupt": self.corrupt, "short": self.short,
               "resyncs": self.resyncs, "skipped_bytes": self.skipped_bytes}
        if self.counter_resets:
            out["counter_resets"] = self.counter_resets
        return out

    def link_counters(self) -> dict:
        """The link statistics since open (``ares.hardware.link_stats``)."""
        return {"transfers": self.transfers, "bytes": self.bytes, "short_packets": self.short_packets,
                "zlps": self.zlps, "timeouts": self.timeouts, "overflows": self.overflows, "resyncs": self.resyncs,
                "dropped_frames": self.dropped, "corrupt_frames": self.corrupt, "short_frames": self.short,
                "stalls": self.stalls}

    def identity(self) -> dict:
        """What the grabber says it is: VID:PID, serial number, manufacturer and product strings."""
        out = {"interface": "USB", "vid_pid": f"{self.cfg.vid:04x}:{self.cfg.pid:04x}"}
        for key, attr in (("serial", "iSerialNumber"), ("manufacturer", "iManufacturer"), ("product", "iProduct")):
            text = _string(self.dev, attr)
            if text:
                out[key] = text
        return out

    def close(self) -> None:
        _dispose(self.dev)


def _dispose(dev) -> None:
    """Let go of a device handle (closing a vanished device must not mask the original error)."""
    try:
        import usb.util

        usb.util.dispose_resources(dev)
    except Exception:  # noqa: BLE001
        pass


def counter_mode(cfg) -> str:
    """How the device's frame counter runs (``<usb_grabber counter=...>``): "continuous" (from
    0 after open, on through every grab), "per_grab" (from 0 at every start) or
    "free_running" (the sensor streams between grabs: checked within a grab only).
    Undeclared: free-running without a 'start' control, else continuous."""
    if cfg.counter:
        return cfg.counter
    return "continuous" if any(c.when == "start" for c in cfg.controls) else "free_running"


def _whole_packets(n: int, packet: int) -> int:
    """``n`` bytes rounded up to whole packets (at least one)."""
    return max(1, -(-int(n) // packet)) * packet


def _max_packet(dev, cfg) -> int:
    """wMaxPacketSize of the grabber's IN endpoint, from its descriptor (512, the USB 2.0
    high-speed bulk size, when the descriptor cannot be read)."""
    try:
        import usb.util

        intf = dev.get_active_configuration()[(cfg.interface, 0)]
        ep = usb.util.find_descriptor(intf, bEndpointAddress=cfg.endpoint)
        return int(ep.wMaxPacketSize) & 0x7FF if ep is not None else 512
    except Exception:  # a device without readable descriptors: the common high-speed size
        return 512


def _string(dev, attr: str) -> str | None:
    """A string descriptor of the device (``iSerialNumber``, ``iProduct`` ...), None when it has none."""
    try:
        import usb.util

        index = getattr(dev, attr, 0)
        return usb.util.get_string(dev, index) if index else None
    except Exception:  # a device that cannot answer string requests has no usable string
        return None


def _serial_of(dev) -> str | None:
    return _string(dev, "iSerialNumber")
