"""The frame header a USB grabber puts before each frame (``header="ares32"``).

32 bytes, little-endian::

    0  sync        4 bytes  A5 5A C3 3C
    4  counter     u32      frame counter of the device (gaps = dropped frames)
    8  width       u16
   10  height      u16
   12  format      u32      PFNC pixel-format code (ares.hardware.pixels.FORMATS)
   16  payload     u32      payload bytes that follow the header
   20  flags       u32      bit 0: the payload CRC below is valid
   24  crc         u32      CRC-32 (zlib) of the payload, when flag bit 0 is set
   28  hcrc        u32      CRC-32 of header bytes 0..27

A reader that finds no sync word where a header must start searches forward for the
next one (``find_sync``) and counts the bytes it skipped.

``header="ares40"``: the same, with the device's time stamp before the header CRC -- 40 bytes::

   28  timestamp   u64      the device clock at the frame's exposure start, in ticks of
                            ``<usb_grabber timestamp_hz>`` (flags bit 1: valid)
   36  hcrc        u32      CRC-32 of header bytes 0..35
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

SYNC = b"\xa5\x5a\xc3\x3c"
SIZE = 32
_FMT = struct.Struct("<4sIHHIIIII")
FLAG_CRC = 1
FLAG_TIMESTAMP = 2  # ares40: the timestamp field is valid
SIZES = {"ares32": 32, "ares40": 40}


@dataclass(frozen=True)
class Header:
    counter: int
    width: int
    height: int
    format_code: int
    payload: int
    flags: int = 0
    crc: int = 0
    timestamp: int | None = None  # ares40: device clock ticks (None in an ares32 header)

    def encode(self, size: int = SIZE) -> bytes:
        flags = self.flags | (FLAG_TIMESTAMP if size == 40 and self.timestamp is not None else 0)
        head = _FMT.pack(SYNC, self.counter & 0xFFFFFFFF, self.width, self.height, self.format_code,
                         self.payload, flags, self.crc, 0)[:28]
        if size == 40:
            head += struct.pack("<Q", int(self.timestamp or 0) & 0xFFFFFFFFFFFFFFFF)
        return head + struct.pack("<I", zlib.crc32(head))


class BadHeader(ValueError):
    """Not a valid header at this position (no sync word, or its own CRC fails)."""


def decode(buf, size: int = SIZE) -> Header:
    b = bytes(buf[:size])
    if len(b) < size:
        raise BadHeader(f"{len(b)} bytes, a header has {size}")
    sync, counter, w, h, code, payload, flags, crc, _ = _FMT.unpack(b[:32])
    if sync != SYNC:
        raise BadHeader("no sync word")
    if zlib.crc32(b[:size - 4]) != struct.unpack("<I", b[size - 4:size])[0]:
        raise BadHeader("header CRC mismatch")
    stamp = struct.unpack("<Q", b[28:36])[0] if size == 40 and flags & FLAG_TIMESTAMP else None
    return Header(counter, w, h, code, payload, flags & ~FLAG_TIMESTAMP, crc, stamp)


def find_sync(buf, start: int = 0) -> int:
    """Index of the next sync word in ``buf`` at or after ``start`` (-1: none)."""
    return bytes(buf).find(SYNC, start) if not isinstance(buf, (bytes, bytearray)) else buf.find(SYNC, start)


def payload_crc(payload) -> int:
    return zlib.crc32(payload)
