"""USB packet rules (issue 36, finding 1) on a strict device model under the project's own
pyusb backend (``EmulatedGrabber``): packets of wMaxPacketSize, transfers ending in a short
packet or a ZLP, an overflow when a packet does not fit the host's read, and the host's
timeout. An FX3-style grabber streams the header inline with the payload."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from ares.errors import HardwareError
from ares.hardware.emulators.usb_backend import EmulatedUsbBackend
from ares.hardware.emulators.usb_device import EmulatedGrabber
from ares.hardware.interfaces import Frame
from ares.hardware.usb import UsbFrameSource
from ares.protocol import load_system

WIRE = Path(__file__).resolve().parents[1] / "protocols" / "sim_wire.xml"


class Pattern:
    def __init__(self, shape, bits):
        self.img = np.random.default_rng(3).integers(0, 1 << bits, shape).astype(np.uint16)

    def grab(self, n):
        for k in range(n):
            yield Frame((self.img + k) % 4096, k)


def _pair(fmt="mono12p", shape=(8, 64), max_packet=512, zlp=True, latency=None, **cfg_kw):
    cfg = dataclasses.replace(load_system(WIRE).usb_grabber, format=fmt, **cfg_kw)
    pattern = Pattern(shape, 12)
    dev = EmulatedGrabber(pattern, cfg, max_packet=max_packet, zlp=zlp, latency=latency)
    src = UsbFrameSource.open(cfg, shape, 12, backend=EmulatedUsbBackend([dev]))
    return src, dev, pattern


def test_the_model_enforces_packets_zlp_and_overflow():
    cfg = dataclasses.replace(load_system(WIRE).usb_grabber, format="mono16", header_packet="inline")
    dev = EmulatedGrabber(Pattern((8, 64), 12), cfg, max_packet=512)  # 32 + 1024 bytes: one transfer
    dev.control(0x40, 0xB1, 2, 0, b"")  # armed for 2 frames
    assert len(dev.bulk_read(0x81, 1024)) == 1024  # two full packets
    assert len(dev.bulk_read(0x81, 512)) == 32  # the short packet ends the transfer
    with pytest.raises(Exception, match=r"Errno 75\] Overflow"):  # a 512-byte packet, 32 bytes of room
        dev.bulk_read(0x81, 32)
    assert dev.overflows == 1
    own = EmulatedGrabber(Pattern((8, 64), 12), dataclasses.replace(cfg, header_packet="own"), max_packet=512)
    own.control(0x40, 0xB1, 1, 0, b"")
    assert [len(own.bulk_read(0x81, n)) for n in (4096, 1024, 512)] == [32, 1024, 0]  # header, payload, ZLP


@pytest.mark.parametrize("max_packet", [512, 1024])
@pytest.mark.parametrize("fmt,shape", [("mono12p", (8, 64)), ("mono16", (16, 128)), ("mono12p", (480, 640))])
def test_fx3_inline_header_frames_arrive_whole(max_packet, fmt, shape):
    """Header and payload in one transfer: the host used to read 32 bytes for the header and
    overflowed on frame 0; it now reads whole packets and parses the header out of the first."""
    src, dev, pattern = _pair(fmt, shape, max_packet, header_packet="inline", chunk_bytes=4096)
    frames = list(src.grab(3)) + list(src.grab(2))
    assert [f.meta["counter"] for f in frames] == [0, 1, 2, 3, 4]
    assert all(np.array_equal(f.data, (pattern.img + k % 3 if k < 3 else pattern.img + k - 3) % 4096)
               for k, f in enumerate(frames))
    assert dev.overflows == 0 and src.stats()["dropped"] == 0 and src.stats()["short"] == 0


@pytest.mark.parametrize("zlp", [True, False])
def test_own_header_packet_with_and_without_zlp(zlp):
    """The header as its own short packet; a payload on a packet boundary ends with a ZLP (or,
    for a device that sends none, the byte count tells the frame's end)."""
    src, dev, pattern = _pair("mono16", (16, 128), 512, zlp=zlp, header_packet="own")
    frames = list(src.grab(4))
    assert [f.meta["counter"] for f in frames] == [0, 1, 2, 3] and dev.overflows == 0
    assert np.array_equal(frames[2].data, (pattern.img + 2) % 4096)


def test_a_short_frame_inline_is_reported_short_and_the_next_is_whole():
    src, dev, _ = _pair("mono12p", (8, 64), 512, header_packet="inline")
    dev.faults["usb_short_at"] = 1
    it = src.grab(3)
    next(it)
    with pytest.raises(Exception, match=r"frame 1 \(device counter 1\) arrived short"):
        next(it)
    assert [f.meta["counter"] for f in src.grab(1)] == [2]  # no false 'dropped'


def test_the_host_timeout_follows_the_frame_time():
    """A 3 s exposure with a 2 s read timeout times out (the model decides in model time);
    with the frame time given, the read waits long enough."""
    src, dev, _ = _pair(latency=lambda: 3.0, header_packet="inline")
    with pytest.raises(HardwareError, match=r"no data on endpoint 0x81 within 2000 ms \(timeout\) at frame 0"):
        next(src.grab(1))
    src.set_frame_time(3.5)
    assert [f.meta["counter"] for f in src.grab(1)] == [0]
