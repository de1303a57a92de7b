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


def read_image(path: str | Path) -> np.ndarray:
    path = Path(path)
    if not path.is_file():
        from ares.safefile import not_a_file

        raise not_a_file(path, "image file")
    from ares.hardware import png, tiff

    try:
        with open(path, "rb") as f:
            data = f.read(len(png.SIGNATURE))
            if data == png.SIGNATURE and os.fstat(f.fileno()).st_size <= 3 * MAX_PIXELS:
                data += f.read()
            elif data[:4] in tiff.SIGNATURES:  # an uncompressed grayscale TIFF: its strips are the pixels
                arr = tiff.read(f, MAX_PIXELS)
                if arr is not None:
                    return arr
    except OSError as exc:
        raise InputError(f"{path}: cannot read the image ({exc.strerror or type(exc).__name__})") from None
    arr = png.decode(data, MAX_PIXELS)  # unfiltered grayscale PNG: inflating is decoding
    if arr is not None:
        return arr
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data) if len(data) > len(png.SIGNATURE) else path) as im:
            # the header's size is checked before any pixel is decoded (a decompression bomb
            # is a few kB on disk and gigabytes in memory)
            if im.width * im.height > MAX_PIXELS:
                raise InputError(f"{path}: image of {im.width}x{im.height} pixels is larger than ARES reads "
                                 f"({MAX_PIXELS // (1 << 20)} Mpx); not decoded")
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
