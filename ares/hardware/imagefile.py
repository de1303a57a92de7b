"""Read one recorded image (PNG/TIFF, 8-16 bit, grayscale) into a 2-D unsigned array.

Shared by every replay source (image lists, EMVA 1288 descriptors). Errors name the file.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from ares.errors import InputError


MAX_PIXELS = 1 << 28  # 268 Mpx (16384 x 16384): larger headers are refused before decoding
# what analysing a frame's pixels takes at the peak (a dark and a flat stack's accumulators,
# maps and the decomposition: ``ares analyze`` peaks 104 bytes a pixel, benchmarks/fuzz.md):
# a frame whose analysis would not fit the machine's available memory is refused from its header
STACK_BYTES_PER_PIXEL = 110


def check_frame_memory(rows: int, cols: int, where) -> None:
    """Before a frame of ``rows`` x ``cols`` is read: its analysis fits this machine's memory."""
    from ares.safefile import check_memory

    check_memory(float(rows) * float(cols) * STACK_BYTES_PER_PIXEL, str(where), f"analysing {cols}x{rows} frames")


def _memory_pixels() -> int:
    """The most pixels a frame may have: ``MAX_PIXELS``, or fewer when the machine's
    available memory would not hold their analysis."""
    from ares.safefile import machine_memory

    total, avail = machine_memory()
    have = avail if avail is not None else total
    return MAX_PIXELS if have is None else int(min(MAX_PIXELS, have // STACK_BYTES_PER_PIXEL))


def _png_size(head: bytes) -> tuple[int, int] | None:
    """(width, height) from a PNG's IHDR (its first chunk, bytes 8-33), else None."""
    import struct

    if len(head) >= 24 and head[12:16] == b"IHDR":
        return struct.unpack(">II", head[16:24])
    return None


def read_image(path: str | Path) -> np.ndarray:
    path = Path(path)
    if not path.is_file():
        from ares.safefile import not_a_file

        raise not_a_file(path, "image file")
    from ares.hardware import png, tiff

    whole = False  # (data holds the whole file)
    try:
        with open(path, "rb") as f:
            data = f.read(len(png.SIGNATURE))
            if data == png.SIGNATURE:  # the size its header claims, checked before the rest is read
                data += f.read(25)
                size = _png_size(data)
                if size is not None and size[0] * size[1] <= MAX_PIXELS:
                    check_frame_memory(size[1], size[0], path)
            if data[:8] == png.SIGNATURE and os.fstat(f.fileno()).st_size <= 3 * MAX_PIXELS:
                data += f.read()
                whole = True
            elif data[:4] in tiff.SIGNATURES:  # an uncompressed grayscale TIFF: its strips are the pixels
                arr = tiff.read(f, _memory_pixels())  # (larger: PIL's header read says why below)
                if arr is not None:
                    return arr
    except OSError as exc:
        raise InputError(f"{path}: cannot read the image ({exc.strerror or type(exc).__name__})") from None
    arr = png.decode(data, MAX_PIXELS)  # unfiltered grayscale PNG: inflating is decoding
    if arr is not None:
        return arr
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data) if whole else path) as im:
            # the header's size is checked before any pixel is decoded (a decompression bomb
            # is a few kB on disk and gigabytes in memory)
            if im.width * im.height > MAX_PIXELS:
                raise InputError(f"{path}: image of {im.width}x{im.height} pixels is larger than ARES reads "
                                 f"({MAX_PIXELS // (1 << 20)} Mpx); not decoded")
            check_frame_memory(im.height, im.width, path)
            im.load()
            if im.mode in ("RGB", "RGBA", "P", "CMYK"):
                raise InputError(f"{path}: colour image (mode {im.mode}); ARES reads raw grayscale data only")
            arr = np.asarray(im)
    except (UnidentifiedImageError, OSError, ValueError, Image.DecompressionBombError) as exc:
        raise InputError(f"{path}: not a readable image ({exc})") from None
    if arr.ndim != 2:
        raise InputError(f"{path}: expected a 2-D grayscale image, got shape {arr.shape}")
    if arr.dtype.kind == "b":
        arr = arr.astype(np.uint8)
    if arr.dtype.kind == "i":
        if arr.min() < 0:
            raise InputError(f"{path}: negative pixel values; raw sensor data are unsigned")
        arr = arr.astype(np.uint16 if arr.max() < 65536 else np.uint32)
    if arr.dtype.kind not in "u":
        raise InputError(f"{path}: pixel type {arr.dtype} is not raw integer data")
    return arr
