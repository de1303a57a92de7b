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
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

SYNC = b"\xa5\x5a\xc3\x3c"
SIZE = 32
_FMT = struct.Struct("<4sIHHIIIII")
FLAG_CRC = 1


@dataclass(frozen=True)
class Header:
    counter: int
    width: int
    height: int
    format_code: int
    payload: int
    flags: int = 0
    crc: int = 0

    def encode(self) -> bytes:
        head = _FMT.pack(SYNC, self.counter & 0xFFFFFFFF, self.width, self.height, self.format_code,
                         self.payload, self.flags, self.crc, 0)[:28]
        return head + struct.pack("<I", zlib.crc32(head))


class BadHeader(ValueError):
    """Not a valid header at this position (no sync word, or its own CRC fails)."""


def decode(buf) -> Header:
    b = bytes(buf[:SIZE])
    if len(b) < SIZE:
        raise BadHeader(f"{len(b)} bytes, a header has {SIZE}")
    sync, counter, w, h, code, payload, flags, crc, hcrc = _FMT.unpack(b)
    if sync != SYNC:
        raise BadHeader("no sync word")
    if zlib.crc32(b[:28]) != hcrc:
        raise BadHeader("header CRC mismatch")
    return Header(counter, w, h, code, payload, flags, crc)


def find_sync(buf, start: int = 0) -> int:
    """Index of the next sync word in ``buf`` at or after ``start`` (-1: none)."""
    return bytes(buf).find(SYNC, start) if not isinstance(buf, (bytes, bytearray)) else buf.find(SYNC, start)


def payload_crc(payload) -> int:
    return zlib.crc32(payload)
