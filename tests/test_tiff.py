"""The uncompressed-TIFF reader (``ares.hardware.tiff``): the pixels Pillow reads for the
files it takes (Pillow's own TIFFs, both byte orders, several strips, strips out of order),
None (Pillow decodes them) for every other kind, and damaged files end as one sentence."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from PIL import Image

from ares.errors import InputError
from ares.hardware import tiff
from ares.hardware.imagefile import MAX_PIXELS, read_image


def handmade(img: np.ndarray, order: str = "<", rows_per_strip: int = 5, reverse: bool = False,
             extra: dict | None = None, short_by: int = 0) -> bytes:
    """A baseline TIFF: strips of ``rows_per_strip`` rows, laid out in reverse order with
    ``reverse``; ``extra`` tags (tag: (type, values)) added or replacing; the last strip's
    byte count ``short_by`` too small."""
    h, w = img.shape
    data = img.astype(np.dtype(order + ("u2" if img.dtype.itemsize == 2 else "u1")))
    strips = [data[r:r + rows_per_strip].tobytes() for r in range(0, h, rows_per_strip)]
    body, offsets = b"", [0] * len(strips)
    for k in (reversed(range(len(strips))) if reverse else range(len(strips))):
        offsets[k] = 8 + len(body)
        body += strips[k]
    counts = [len(s) for s in strips]
    counts[-1] -= short_by
    tags = {256: (4, [w]), 257: (4, [h]), 258: (3, [8 * img.dtype.itemsize]), 259: (3, [1]), 262: (3, [1]),
            273: (4, offsets), 277: (3, [1]), 278: (4, [rows_per_strip]), 279: (4, counts), 305: (2, b"x\0")}
    tags.update(extra or {})
    ifd_at = 8 + len(body)
    arrays, entries = b"", b""
    after = ifd_at + 2 + 12 * len(tags) + 4
    for tag in sorted(tags):
        typ, vals = tags[tag]
        raw = bytes(vals) if typ == 2 else struct.pack(order + {3: "H", 4: "I"}[typ] * len(vals), *vals)
        n = len(vals)
        if len(raw) <= 4:
            entries += struct.pack(order + "HHI", tag, typ, n) + raw.ljust(4, b"\0")
        else:
            entries += struct.pack(order + "HHII", tag, typ, n, after + len(arrays))
            arrays += raw
    head = (b"II*\0" if order == "<" else b"MM\0*") + struct.pack(order + "I", ifd_at)
    return head + body + struct.pack(order + "H", len(tags)) + entries + b"\0\0\0\0" + arrays


def _img(dtype, shape=(23, 17), seed=1):
    hi = 256 if dtype == np.uint8 else 65536
    return np.random.default_rng(seed).integers(0, hi, shape).astype(dtype)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("order", ["<", ">"])
@pytest.mark.parametrize("rows,reverse", [(5, False), (5, True), (23, False), (1, True)])
def test_strips_read_as_pillow_reads_them(tmp_path, dtype, order, rows, reverse):
    img = _img(dtype)
    p = tmp_path / "a.tif"
    p.write_bytes(handmade(img, order, rows, reverse))
    with open(p, "rb") as f:
        out = tiff.read(f, MAX_PIXELS)
    assert out is not None and out.dtype == dtype and out.dtype.isnative and out.flags.c_contiguous
    assert np.array_equal(out, img)
    assert np.array_equal(np.asarray(Image.open(p)), img)  # the file is a TIFF Pillow reads alike
    assert np.array_equal(read_image(p), img)


@pytest.mark.parametrize("mode,dtype", [("I;16", np.uint16), ("I;16B", np.uint16), ("L", np.uint8)])
def test_pillows_own_tiffs(tmp_path, mode, dtype):
    img = _img(dtype, (301, 257), 2)  # larger than one of Pillow's strips
    p = tmp_path / "b.tif"
    im = Image.fromarray(img) if mode != "I;16B" else Image.frombytes(mode, img.shape[::-1], img.astype(">u2").tobytes())
    im.save(p)
    with open(p, "rb") as f:
        out = tiff.read(f, MAX_PIXELS)
    assert out is not None and np.array_equal(out, img) and np.array_equal(out, np.asarray(Image.open(p)).astype(dtype))


@pytest.mark.parametrize("extra", [{259: (3, [5])}, {262: (3, [0])}, {277: (3, [3])}, {258: (3, [12])},
                                   {339: (3, [2])}, {317: (3, [2])}, {322: (4, [16])}, {320: (3, [0] * 768)}])
def test_other_kinds_are_left_to_pillow(tmp_path, extra):
    """Compressed, min-is-white, RGB, 12-bit, signed, predictor, tiled, palette: None."""
    p = tmp_path / "c.tif"
    p.write_bytes(handmade(_img(np.uint8), extra=extra))
    with open(p, "rb") as f:
        assert tiff.read(f, MAX_PIXELS) is None


def test_compressed_tiff_still_read_by_pillow(tmp_path):
    img = _img(np.uint8, (40, 30), 3)
    p = tmp_path / "d.tif"
    Image.fromarray(img).save(p, compression="packbits")
    with open(p, "rb") as f:
        assert tiff.read(f, MAX_PIXELS) is None
    assert np.array_equal(read_image(p), img)


def test_damaged_files_left_to_pillow_and_one_sentence(tmp_path):
    img = _img(np.uint16)
    p = tmp_path / "e.tif"
    full = handmade(img)
    for bad in (handmade(img, short_by=2), full[:60], full[:8] + b"\xff" * 20):
        p.write_bytes(bad)
        with open(p, "rb") as f:
            assert tiff.read(f, MAX_PIXELS) is None
    p.write_bytes(full[:60])
    with pytest.raises(InputError, match=r"e\.tif"):
        read_image(p)


def test_size_limit(tmp_path):
    p = tmp_path / "f.tif"
    p.write_bytes(handmade(_img(np.uint8)))
    with open(p, "rb") as f:
        assert tiff.read(f, 23 * 17 - 1) is None
        assert tiff.read(f, 23 * 17) is not None
