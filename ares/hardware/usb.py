"""Frames from a USB bulk-endpoint frame grabber (pyusb): a ``FrameSource``.

Each frame is one bulk read of ``header_bytes + rows*cols*bytes_per_pixel`` from the
declared IN endpoint; pixels are ``mono8``, ``mono16le`` or ``mono16be``. A read that
times out, a device that vanishes, a short transfer, or a code above the ADC range ends
in a ``HardwareError`` naming the grabber.
"""

from __future__ import annotations

import time

import numpy as np

from ares.errors import DeviceGone, FrameError, HardwareError
from ares.hardware.interfaces import Frame

_DTYPES = {"mono8": np.dtype("u1"), "mono16le": np.dtype("<u2"), "mono16be": np.dtype(">u2")}


class UsbFrameSource:
    def __init__(self, device, cfg, shape: tuple[int, int], bit_depth: int):
        self.dev, self.cfg = device, cfg
        self.name = f"USB frame grabber '{cfg.name}' ({cfg.vid:04x}:{cfg.pid:04x})"
        self.shape, self.bit_depth = tuple(shape), int(bit_depth)
        self.dtype = _DTYPES[cfg.format]
        self.frame_bytes = cfg.header_bytes + shape[0] * shape[1] * self.dtype.itemsize
        self.count = 0

    @classmethod
    def open(cls, cfg, shape, bit_depth, backend=None) -> "UsbFrameSource":
        import usb.core

        try:
            dev = usb.core.find(idVendor=cfg.vid, idProduct=cfg.pid, backend=backend)
        except usb.core.NoBackendError:
            raise DeviceGone(f"USB frame grabber '{cfg.name}': no USB backend (libusb) is installed") from None
        if dev is None:
            raise DeviceGone(f"USB frame grabber '{cfg.name}' ({cfg.vid:04x}:{cfg.pid:04x}) is not connected")
        try:
            dev.set_configuration()
        except usb.core.USBError as exc:
            raise DeviceGone(f"USB frame grabber '{cfg.name}': cannot configure the device ({exc})") from None
        src = cls(dev, cfg, shape, bit_depth)
        src._backend = backend
        return src

    def reconnect(self) -> None:
        """Find the grabber by VID/PID again and configure it (``DeviceGone`` while away)."""
        again = type(self).open(self.cfg, self.shape, self.bit_depth, backend=getattr(self, "_backend", None))
        self.dev = again.dev

    def _read(self) -> bytes:
        import usb.core

        try:
            data = self.dev.read(self.cfg.endpoint, self.frame_bytes, timeout=self.cfg.timeout_ms)
        except usb.core.USBTimeoutError:
            raise HardwareError(f"{self.name}: no frame within {self.cfg.timeout_ms} ms (timeout)") from None
        except usb.core.USBError as exc:
            if getattr(exc, "errno", None) == 19 or "No such device" in str(exc):
                raise DeviceGone(f"{self.name}: device disconnected") from None
            raise HardwareError(f"{self.name}: USB error on endpoint 0x{self.cfg.endpoint:02x} ({exc})") from None
        return bytes(data)

    def grab(self, n: int):
        for _ in range(n):
            raw = self._read()
            if len(raw) != self.frame_bytes:
                raise FrameError(f"{self.name}: frame {self.count} arrived short ({len(raw)} of {self.frame_bytes} bytes)")
            px = np.frombuffer(raw, dtype=self.dtype, offset=self.cfg.header_bytes).reshape(self.shape)
            data = px.astype(np.uint16 if self.dtype.itemsize == 2 else np.uint8)
            if int(data.max()) >= (1 << self.bit_depth):
                raise FrameError(f"{self.name}: frame {self.count} is corrupt (code {int(data.max())} "
                                 f"above the {self.bit_depth}-bit range)")
            yield Frame(data, self.count, time.time(), {"header": raw[:self.cfg.header_bytes]})
            self.count += 1

    def close(self) -> None:
        try:
            import usb.util

            usb.util.dispose_resources(self.dev)
        except Exception:  # closing a vanished device must not mask the original error
            pass
