"""A fast reader for the TIFFs raw sensor data are usually stored in: one grayscale
channel of 8 or 16 unsigned bits, uncompressed, in strips -- what Pillow, libtiff and
camera software write by default for an image to be measured (EMVA 1288 descriptor sets).

Such a file's pixels are its strips' bytes: ``read`` parses the first directory and reads
the strips straight into the array (one ``readinto`` when they follow each other, as
writers lay them out), where Pillow decodes into its own image and numpy copies that again:
a 2048x1536 16-bit image in ~2 ms against Pillow's ~8 ms (``benchmarks/
twelve_mp_peer_2048x1536.md``). Anything else -- compressed, tiled, several samples, a
palette, min-is-white, signed or float samples, a predictor, a directory or strip that
does not add up -- returns None, and the caller decodes the file with Pillow (which also
words the error of a damaged file). The pixels are Pillow's in every case (tested).
"""

from __future__ import annotations

import struct

import numpy as np

SIGNATURES = (b"II*\x00", b"MM\x00*")
_SIZES = {1: 1, 3: 2, 4: 4, 16: 8}  # BYTE, SHORT, LONG, LONG8 (BigTIFF is not read here)
_FORMATS = {1: "B", 3: "H", 4: "I"}
# tag -> the values this reader takes (None: any); a tag not listed is metadata, ignored
_ACCEPT = {258: (8, 16), 259: (1,), 262: (1,), 277: (1,), 284: (1,), 317: (1,), 339: (1,), 266: (1,)}
_REFUSE = {320, 322, 323, 324, 325, 338}  # colour map, tiles, extra samples


def read(f, max_pixels: int) -> np.ndarray | None:
    """The image of the open TIFF file ``f`` (uint8 or uint16, rows x columns), or None if it
    is not a TIFF this reader takes (see the module text); no more than ``max_pixels``."""
    try:
        f.seek(0)
        head = f.read(8)
        if len(head) != 8 or head[:4] not in SIGNATURES:
            return None
        e = "<" if head[:2] == b"II" else ">"
        f.seek(struct.unpack(e + "I", head[4:])[0])
        raw = f.read(2)
        if len(raw) != 2:
            return None
        n = struct.unpack(e + "H", raw)[0]
        entries = f.read(12 * n)
        if len(entries) != 12 * n:
            return None
        tags = {}
        for k in range(n):
            tag, typ, count = struct.unpack_from(e + "HHI", entries, 12 * k)
            if tag in _REFUSE:
                return None
            if typ not in _FORMATS or count > 1 << 20:
                if tag in _ACCEPT or tag in (256, 257, 273, 278, 279):
                    return None
                continue
            size = _SIZES[typ] * count
            if size <= 4:
                data = entries[12 * k + 8:12 * k + 8 + size]
            else:
                pos = f.tell()
                f.seek(struct.unpack_from(e + "I", entries, 12 * k + 8)[0])
                data = f.read(size)
                f.seek(pos)
                if len(data) != size:
                    return None
            tags[tag] = struct.unpack(e + _FORMATS[typ] * count, data)
        for tag, ok in _ACCEPT.items():
            if tag in tags and any(v not in ok for v in tags[tag]):
                return None
        if 262 not in tags or not {256, 257, 273, 279} <= tags.keys() or len(tags[256]) != 1 or len(tags[257]) != 1:
            return None
        width, height = tags[256][0], tags[257][0]
        depth = tags.get(258, (1,))[0]
        if depth not in (8, 16) or not 0 < width * height <= max_pixels:
            return None
        offsets, counts = tags[273], tags[279]
        rows_per_strip = tags.get(278, (height,))[0] or height
        line = width * depth // 8
        strips = -(-height // rows_per_strip)
        if len(offsets) != strips or len(counts) != strips:
            return None
        dtype = np.dtype(np.uint8) if depth == 8 else np.dtype(e + "u2")
        out = np.empty((height, width), dtype)
        buf = out.reshape(-1).view(np.uint8)
        done = k = 0
        while k < strips:  # strips that follow each other in the file: one read
            start, run = offsets[k], 0
            while k < strips and (not run or offsets[k] == start + run):
                want = min(rows_per_strip, height - k * rows_per_strip) * line
                if counts[k] < want:
                    return None
                run += want
                k += 1
            f.seek(start)
            if f.readinto(buf[done:done + run]) != run:
                return None
            done += run
    except (OSError, struct.error, ValueError, MemoryError):
        return None
    return out if dtype.isnative else out.astype(dtype.newbyteorder("="))
