"""Pixel formats, channel order and the frame header, against bit-by-bit references."""

from __future__ import annotations

import numpy as np
import pytest

from ares.errors import FrameError, InputError
from ares.hardware import frame_header as fh
from ares.hardware.pixels import FORMATS, from_wire_order, pack, pixel_format, to_wire_order, unpack


def _bits_reference(codes, bits: int) -> bytes:
    """PFNC LSB-first packing, one bit at a time (the definition, not the fast code)."""
    stream = []
    for c in codes:
        stream.extend((int(c) >> k) & 1 for k in range(bits))
    stream.extend([0] * (-len(stream) % 8))
    return bytes(sum(stream[i + k] << k for k in range(8)) for i in range(0, len(stream), 8))


@pytest.mark.parametrize("name", sorted(FORMATS))
def test_pack_unpack_round_trip(name):
    f = FORMATS[name]
    rng = np.random.default_rng(7)
    shape = (6, 20)  # 120 pixels: whole packing groups for every format
    img = rng.integers(0, 1 << f.bits, shape).astype(np.uint16)
    img[0, :4] = [0, (1 << f.bits) - 1, 1, 1 << (f.bits - 1)]  # edges of the code range
    payload = pack(img, f)
    assert len(payload) == f.payload_bytes(img.size)
    back = unpack(payload, f, shape)
    assert back.dtype == (np.uint8 if f.container == 1 else np.uint16)
    assert np.array_equal(back, img)


@pytest.mark.parametrize("name", ["mono10p", "mono12p", "mono14p"])
def test_packed_layout_is_pfnc_lsb_first(name):
    f = FORMATS[name]
    codes = np.random.default_rng(3).integers(0, 1 << f.bits, 16)
    assert pack(codes, f) == _bits_reference(codes, f.bits)
    # and the unpacker reads the reference layout, also from an offset view of a larger buffer
    buf = bytearray(b"\x00" * 5) + _bits_reference(codes, f.bits)
    assert np.array_equal(unpack(memoryview(buf)[5:], f, (2, 8)).ravel(), codes)


def test_mono12p_known_bytes():
    # two pixels 0xABC, 0x123 -> bytes BC 3A 12 (GenICam PFNC Mono12p)
    assert pack(np.array([0xABC, 0x123]), FORMATS["mono12p"]) == bytes([0xBC, 0x3A, 0x12])
    assert pack(np.array([0x1234]), FORMATS["mono16"]) == b"\x34\x12"
    assert pack(np.array([0x1234]), FORMATS["mono16be"]) == b"\x12\x34"


def test_format_errors():
    with pytest.raises(InputError, match="unknown pixel format 'mono11'"):
        pixel_format("mono11")
    assert pixel_format("mono16le") is FORMATS["mono16"]
    with pytest.raises(FrameError, match="short"):
        unpack(b"\x00" * 10, FORMATS["mono12p"], (4, 4))
    with pytest.raises(InputError, match="does not fit the 12-bit format"):
        pack(np.array([4096, 0]), FORMATS["mono12p"])


@pytest.mark.parametrize("order", ["channel_rows", "channel_planes"])
@pytest.mark.parametrize("channels", [2, 4])
def test_channel_wire_order_round_trip(order, channels):
    img = np.arange(6 * 16, dtype=np.uint16).reshape(6, 16)
    wire = to_wire_order(img, order, channels, "column")
    assert not np.array_equal(wire, img)
    if order == "channel_rows":  # row 0 starts with ADC 0's columns 0, N, 2N ...
        assert list(wire[0, :3]) == [0, channels, 2 * channels]
    assert np.array_equal(from_wire_order(wire, order, channels, "column"), img)
    assert from_wire_order(img, "image", channels, "column") is img


def test_header_round_trip_and_damage():
    h = fh.Header(7, 640, 480, FORMATS["mono12p"].code, 460800, fh.FLAG_CRC, 0xDEADBEEF)
    raw = h.encode()
    assert len(raw) == fh.SIZE and raw[:4] == fh.SYNC
    assert fh.decode(raw) == h
    bad = bytearray(raw)
    bad[9] ^= 1  # width bit flipped: the header's own CRC catches it
    with pytest.raises(fh.BadHeader, match="CRC"):
        fh.decode(bad)
    with pytest.raises(fh.BadHeader, match="sync"):
        fh.decode(b"\x00" + raw[1:])
    assert fh.find_sync(b"xyz" + raw) == 3
