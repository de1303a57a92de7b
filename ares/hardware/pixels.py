"""Pixel formats on the wire: packed and unpacked mono 8..16 bit, and ADC channel order.

Names follow the GenICam Pixel Format Naming Convention (PFNC 2.x):

* ``mono8``: one byte per pixel;
* ``mono10`` / ``mono12`` / ``mono14`` / ``mono16`` (alias ``mono16le``): one little-endian
  16-bit word per pixel, the code in the low bits; ``mono16be``: big-endian words;
* ``mono10p`` / ``mono12p`` / ``mono14p``: packed, LSB first -- pixel ``i`` occupies bits
  ``i*b .. i*b+b-1`` of the little-endian bit stream (Mono12p: 2 pixels in 3 bytes,
  Mono10p: 4 in 5, Mono14p: 4 in 7).

``unpack`` is vectorised: per phase of the packing period, one strided little-endian
word view of the byte buffer, one shift and one mask written straight into the output
(no per-pixel Python, no byte copies for Mono12p). ``pack`` is the inverse (the emulated
grabber uses it); both are checked against a bit-by-bit reference in the tests.

Channel order: a sensor with several ADCs may send each row (or the frame) channel by
channel; ``from_wire_order`` puts the pixels back in image order (``ares.hardware.usb``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ares.errors import FrameError, InputError


@dataclass(frozen=True)
class PixelFormat:
    name: str
    bits: int  # significant bits per pixel
    packed: bool
    container: int  # bytes per pixel when unpacked (1 or 2)
    big_endian: bool = False
    code: int = 0  # PFNC code (the wire header carries it)

    def payload_bytes(self, n_pixels: int) -> int:
        if self.packed:
            return (n_pixels * self.bits + 7) // 8
        return n_pixels * self.container


# PFNC codes (GenICam SFNC pixel format values) so a header names the format unambiguously.
FORMATS: dict[str, PixelFormat] = {f.name: f for f in (
    PixelFormat("mono8", 8, False, 1, code=0x01080001),
    PixelFormat("mono10", 10, False, 2, code=0x01100003),
    PixelFormat("mono12", 12, False, 2, code=0x01100005),
    PixelFormat("mono14", 14, False, 2, code=0x01100025),
    PixelFormat("mono16", 16, False, 2, code=0x01100007),
    PixelFormat("mono16be", 16, False, 2, big_endian=True, code=0x81100007),  # not PFNC: high bit marks BE
    PixelFormat("mono10p", 10, True, 2, code=0x010A0046),
    PixelFormat("mono12p", 12, True, 2, code=0x010C0047),
    PixelFormat("mono14p", 14, True, 2, code=0x010E0104),
)}
ALIASES = {"mono16le": "mono16"}
BY_CODE = {f.code: f for f in FORMATS.values()}


def pixel_format(name: str) -> PixelFormat:
    key = ALIASES.get(name.lower(), name.lower())
    try:
        return FORMATS[key]
    except KeyError:
        raise InputError(f"unknown pixel format '{name}' (known: {', '.join(FORMATS)}, mono16le)") from None


def _period(bits: int) -> tuple[int, int]:
    """(pixels, bytes) of one packing period: the smallest group that ends on a byte."""
    px = 8 // np.gcd(bits, 8)
    return int(px), int(px * bits // 8)


def unpack(buf, fmt: PixelFormat, shape: tuple[int, int], out: np.ndarray | None = None) -> np.ndarray:
    """Bytes of one frame's payload -> ``shape`` array (uint8 for mono8, else uint16).
    ``buf`` is any buffer; it must hold at least ``fmt.payload_bytes(rows*cols)`` bytes."""
    n = int(shape[0]) * int(shape[1])
    need = fmt.payload_bytes(n)
    raw = np.frombuffer(buf, dtype=np.uint8)
    if raw.size < need:
        raise FrameError(f"{fmt.name} payload of {raw.size} bytes is short ({need} needed for {shape[1]}x{shape[0]})")
    if not fmt.packed:
        if fmt.container == 1:
            data = raw[:need]
            return data.reshape(shape).copy() if out is None else _into(out, data.reshape(shape))
        dt = np.dtype(">u2" if fmt.big_endian else "<u2")
        words = raw[:need].view(dt).reshape(shape)
        if out is None:
            out = np.empty(shape, np.uint16)
        out[...] = words
        return out
    if out is None:
        out = np.empty(shape, np.uint16)
    flat = out.reshape(-1)
    px, nb = _period(fmt.bits)
    if n % px:
        raise FrameError(f"{fmt.name}: {n} pixels are not a whole number of {px}-pixel packing groups")
    groups = n // px
    mask = np.uint16((1 << fmt.bits) - 1)
    padded = None
    for j in range(px):
        bit = j * fmt.bits
        byte, shift = divmod(bit, 8)
        if shift + fmt.bits <= 16:
            word = np.ndarray((groups,), dtype="<u2", buffer=raw, offset=byte, strides=(nb,))
            dst = flat[j::px]
            if shift:
                np.right_shift(word, shift, out=dst)
                if shift + fmt.bits < 16:
                    np.bitwise_and(dst, mask, out=dst)
            else:
                np.bitwise_and(word, mask, out=dst)
        else:  # straddles three bytes: a 32-bit window (the buffer padded so the last one fits)
            if padded is None:
                padded = np.zeros(need + 4, np.uint8)
                padded[:need] = raw[:need]
            word = np.ndarray((groups,), dtype="<u4", buffer=padded, offset=byte, strides=(nb,))
            flat[j::px] = (word >> np.uint32(shift)) & np.uint32(mask)
    return out


def _into(out: np.ndarray, data: np.ndarray) -> np.ndarray:
    out[...] = data
    return out


def pack(frame: np.ndarray, fmt: PixelFormat) -> bytes:
    """Image -> payload bytes in ``fmt`` (codes above ``fmt.bits`` are an error)."""
    a = np.ascontiguousarray(frame).reshape(-1)
    if a.size and int(a.max()) >= (1 << fmt.bits):
        raise InputError(f"code {int(a.max())} does not fit the {fmt.bits}-bit format {fmt.name}")
    if not fmt.packed:
        if fmt.container == 1:
            return a.astype(np.uint8).tobytes()
        return a.astype(">u2" if fmt.big_endian else "<u2").tobytes()
    px, nb = _period(fmt.bits)
    if a.size % px:
        raise InputError(f"{fmt.name}: {a.size} pixels are not a whole number of {px}-pixel packing groups")
    g = a.reshape(-1, px).astype(np.uint64)
    word = np.zeros(g.shape[0], np.uint64)
    for j in range(px):
        word |= g[:, j] << np.uint64(j * fmt.bits)
    out = np.empty((g.shape[0], nb), np.uint8)
    for m in range(nb):
        out[:, m] = (word >> np.uint64(8 * m)) & np.uint64(0xFF)
    return out.tobytes()


# ---------------------------------------------------------------- channel order on the wire

WIRE_ORDERS = ("image", "channel_rows", "channel_planes")


def to_wire_order(img: np.ndarray, order: str, channels: int, interleave: str) -> np.ndarray:
    """Image order -> wire order (the emulator's side of ``from_wire_order``)."""
    if order == "image" or channels == 1:
        return img
    if interleave != "column":
        raise InputError(f"wire order '{order}' is defined for column-interleaved ADCs, not '{interleave}'")
    rows, cols = img.shape
    parts = img.reshape(rows, cols // channels, channels)  # [r, k, c] = pixel (r, k*channels + c)
    if order == "channel_rows":  # each row: channel 0's pixels, then channel 1's ...
        return np.ascontiguousarray(parts.transpose(0, 2, 1)).reshape(rows, cols)
    return np.ascontiguousarray(parts.transpose(2, 0, 1)).reshape(rows, cols)  # channel_planes


def from_wire_order(wire: np.ndarray, order: str, channels: int, interleave: str) -> np.ndarray:
    """Pixels as they arrived -> image order: with ``channel_rows`` every row carries ADC 0's
    columns (0, N, 2N...) then ADC 1's (1, N+1...); with ``channel_planes`` the frame carries
    all of ADC 0's pixels, then ADC 1's. One vectorised copy."""
    if order == "image" or channels == 1:
        return wire
    if interleave != "column":
        raise InputError(f"wire order '{order}' is defined for column-interleaved ADCs, not '{interleave}'")
    rows, cols = wire.shape
    if order == "channel_rows":
        src = wire.reshape(rows, channels, cols // channels).transpose(0, 2, 1)
    else:
        src = wire.reshape(channels, rows, cols // channels).transpose(1, 2, 0)
    return np.ascontiguousarray(src).reshape(rows, cols)
