"""The unfiltered-PNG reader (``ares.hardware.png``): Pillow's pixels for the files it takes,
None (Pillow decodes them) for every other kind, and damaged files end as one sentence."""

from __future__ import annotations

import io
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ares.errors import InputError
from ares.hardware import png
from ares.hardware.imagefile import MAX_PIXELS, read_image

REF = Path(__file__).resolve().parents[2] / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / "images"


def chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def unfiltered_png(img: np.ndarray, *, colour: int = 0, interlace: int = 0, filters=None, idat_parts: int = 3,
                   extra: tuple = (), depth: int | None = None) -> bytes:
    """A PNG written the way the reader expects (or, with the keywords, the ways it does not)."""
    h, w = img.shape
    depth = depth or 8 * img.dtype.itemsize
    rows = img.astype(">u2" if img.dtype.itemsize == 2 else np.uint8).reshape(h, -1).view(np.uint8)
    f = np.zeros((h, 1), np.uint8) if filters is None else np.asarray(filters, np.uint8).reshape(h, 1)
    data = zlib.compress(np.hstack([f, rows]).tobytes(), 6)
    cuts = np.linspace(0, len(data), idat_parts + 1).astype(int)
    out = png.SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, interlace))
    out += b"".join(chunk(k, b) for k, b in extra)
    out += b"".join(chunk(b"IDAT", data[a:b]) for a, b in zip(cuts[:-1], cuts[1:]))
    return out + chunk(b"IEND", b"")


@pytest.mark.parametrize("dtype,hi", [(np.uint16, 65536), (np.uint16, 4096), (np.uint8, 256)])
def test_unfiltered_grayscale_decodes_to_the_pixels(dtype, hi):
    img = np.random.default_rng(1).integers(0, hi, (37, 53)).astype(dtype)
    data = unfiltered_png(img, extra=((b"gAMA", b"\0\0\xb1\x8f"), (b"tEXt", b"k\0v")))
    out = png.decode(data, MAX_PIXELS)
    assert out is not None and out.dtype == dtype and out.flags.c_contiguous
    assert np.array_equal(out, img)
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(data))), img)  # and Pillow reads the same file alike


def test_the_reference_set_takes_the_fast_path_with_pillows_pixels():
    files = sorted(REF.glob("*.png"))[::37]
    if not files:
        pytest.skip(f"{REF} not present")
    for f in files:
        out = png.decode(f.read_bytes(), MAX_PIXELS)
        assert out is not None, f
        assert np.array_equal(out, np.asarray(Image.open(f))), f


def _damaged(img):
    good = unfiltered_png(img)
    i = good.index(b"IDAT") + 20
    return {
        "filtered rows (Pillow's own writer)": None,
        "one Sub-filtered row": unfiltered_png(img, filters=[0] * 5 + [1] + [0] * 6),
        "RGB": unfiltered_png(np.repeat(img, 3, axis=1), colour=2),
        "4-bit": unfiltered_png(img, depth=4),
        "interlaced": unfiltered_png(img, interlace=1),
        "palette chunk": unfiltered_png(img, extra=((b"PLTE", b"\0\0\0"),)),
        "IDAT CRC": good[:i] + bytes([good[i] ^ 1]) + good[i + 1:],
        "no IEND": good[:-12],
        "cut in an IDAT": good[:i],
        "not a PNG": b"GIF89a" + good[6:],
    }


@pytest.mark.parametrize("case", list(_damaged(np.zeros((12, 9), np.uint8))))
def test_every_other_kind_is_left_to_pillow(tmp_path, case):
    img = np.random.default_rng(2).integers(0, 256, (12, 9)).astype(np.uint8)
    data = _damaged(img)[case]
    if data is None:
        b = io.BytesIO()
        Image.fromarray(img).save(b, format="PNG")
        data = b.getvalue()
    assert png.decode(data, MAX_PIXELS) is None
    p = tmp_path / "x.png"
    p.write_bytes(data)
    try:
        pil = np.asarray(Image.open(p))
    except Exception:  # Pillow cannot read it either: one sentence naming the file
        with pytest.raises(InputError, match="x.png"):
            read_image(p)
        return
    if pil.ndim == 2 and case != "4-bit":
        assert np.array_equal(read_image(p), pil)


def test_a_header_larger_than_allowed_is_not_inflated():
    img = np.zeros((40, 50), np.uint16)
    assert png.decode(unfiltered_png(img), 40 * 50 - 1) is None
    assert png.decode(unfiltered_png(img), 40 * 50) is not None


def test_extra_bytes_after_the_image_data_are_not_taken():
    img = np.arange(12, dtype=np.uint8).reshape(3, 4)
    raw = np.hstack([np.zeros((3, 1), np.uint8), img]).tobytes() + b"extra"
    data = (png.SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", 4, 3, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    assert png.decode(data, MAX_PIXELS) is None  # too long for its header: Pillow decides


def test_zlib_inflates_the_same_pixels_when_isal_is_missing(monkeypatch):
    img = np.random.default_rng(3).integers(0, 4096, (20, 30)).astype(np.uint16)
    data = unfiltered_png(img)
    monkeypatch.setattr(png, "_inflate", zlib)
    assert np.array_equal(png.decode(data, MAX_PIXELS), img)
    i = data.index(b"IDAT") + 30  # a flipped byte inside the stream, its CRC made to match
    body_start = data.index(b"IDAT")
    n = int.from_bytes(data[body_start - 4:body_start], "big")
    body = bytearray(data[body_start:body_start + 4 + n])
    body[i - body_start] ^= 0xFF
    forged = data[:body_start] + bytes(body) + zlib.crc32(bytes(body)).to_bytes(4, "big") + data[body_start + 8 + n:]
    assert png.decode(forged, MAX_PIXELS) is None  # zlib's own checks refuse it: Pillow words the error
    monkeypatch.undo()
    assert png.decode(forged, MAX_PIXELS) is None  # and ISA-L's
