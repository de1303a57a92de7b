"""Recorded frame stacks from files, frame by frame (never the whole stack in memory).

Accepted specs (any mix, in order; their frames are concatenated):

* PNG/TIFF images, one frame each (``read_image``), or a folder of them (sorted);
* ``.npy``: a 2-D frame or a 3-D (frames, rows, cols) stack (read frame by frame);
* ``.npz``: every array in it, or ``file.npz:name`` for one;
* HDF5: ``file.h5:/path/to/dataset`` (2-D or 3-D dataset, read one frame at a time);
  a bare ``file.h5`` works when it holds exactly one 2-D/3-D dataset.

Every problem (missing file, unreadable/corrupt data, wrong dimensions, frames of
different shapes) raises ``InputError`` with one sentence naming the file. A shape read
from a header (``.npy``/``.npz``/HDF5, a PNG's IHDR) is checked before anything is
allocated: a frame of at most ``MAX_PIXELS`` (the image reader's limit) whose analysis fits
the machine's available memory (``check_frame_memory``), and no more data than the file
holds (an HDF5 dataset whose chunks were never written is refused: its frames would be
fill values, not data). An ``.npz`` member is read frame by frame from the archive, as a
``.npy`` is, and one that inflates more than ``MAX_DEFLATE_RATIO`` times is refused (a
compression bomb: 75 MB that claim 16 GiB). Data of any byte order are converted to the
machine's (a ``>u2`` stack is a valid NumPy file; the kernels take native data only).
"""

from __future__ import annotations

import os
import zipfile
import zlib
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from ares.errors import InputError
from ares.hardware.imagefile import MAX_PIXELS, check_frame_memory, read_image

__all__ = ["iter_frames", "stack_shape", "load_stack", "split_spec", "IMAGE_SUFFIXES"]

IMAGE_SUFFIXES = (".png", ".tif", ".tiff")
_H5_SUFFIXES = (".h5", ".hdf5", ".hdf")
# image data deflate 2-10x (noise does not compress); an archive member claiming more is refused
MAX_DEFLATE_RATIO = 100


def split_spec(spec: str) -> tuple[Path, str | None]:
    """(file, inner name) of a spec: ``file.h5:/dataset`` -> (file.h5, /dataset); ``file.npz:name``."""
    s = str(spec)
    low = s.lower()
    for suf in _H5_SUFFIXES + (".npz",):
        i = low.find(suf + ":")
        if i >= 0:
            return Path(s[: i + len(suf)]), s[i + len(suf) + 1 :]
    return Path(s), None


def _check_ndim(arr_shape, where: str) -> None:
    if len(arr_shape) not in (2, 3):
        raise InputError(f"{where}: expected a 2-D frame or a 3-D (frames, rows, cols) stack, got shape {tuple(arr_shape)}")


def _check_frame_size(shape, where: str) -> None:
    """A frame of the header's shape fits the limit (checked before allocating it)."""
    rows, cols = (int(n) for n in shape[-2:])
    if rows * cols > MAX_PIXELS:
        raise InputError(f"{where}: the header claims {cols}x{rows} frames ({rows * cols} pixels), more than a frame "
                         f"can have ({MAX_PIXELS} pixels, {MAX_PIXELS >> 20} Mpx); not read")


def _check_memory(shape, where: str) -> None:
    """The analysis of frames of the header's shape fits the machine's available memory."""
    check_frame_memory(int(shape[-2]), int(shape[-1]), where)


def _native(a: np.ndarray) -> np.ndarray:
    """``a`` in the machine's byte order (a big-endian ``>u2`` frame converted)."""
    return a if a.dtype.isnative else a.astype(a.dtype.newbyteorder("="))


def _check_holds(shape, dtype, available: int, where: str) -> None:
    """The data the header's shape needs are in the file (``available`` bytes after the header)."""
    need = int(np.prod([int(n) for n in shape], dtype=object)) * dtype.itemsize
    if need > available:
        raise InputError(f"{where}: the header claims shape {tuple(int(n) for n in shape)} ({need} bytes of "
                         f"{dtype}) but the file holds {available} bytes of data; truncated or corrupt, not read")


def _frames_of_array(a, where: str) -> Iterator[np.ndarray]:
    _check_ndim(a.shape, where)
    _check_frame_size(a.shape, where)
    if a.dtype.kind not in "uif" and a.dtype.kind != "b":
        raise InputError(f"{where}: data of type {a.dtype} are not image data")
    if a.ndim == 2:
        yield _native(np.asarray(a))
    else:
        for i in range(a.shape[0]):
            yield _native(np.asarray(a[i]))


def _check_written(ds, where: str) -> None:
    """An HDF5 dataset's frames are stored, not only claimed: a chunked dataset with chunks
    never written (or a contiguous one never allocated) would give fill values -- and a
    header claiming 1e12 pixels would be read for minutes."""
    shape, nbytes = ds.shape, int(np.prod([int(n) for n in ds.shape], dtype=object)) * ds.dtype.itemsize
    if nbytes == 0:
        return
    if ds.chunks is None:
        stored = ds.id.get_storage_size()
        if stored < nbytes and ds.compression is None:
            raise InputError(f"{where}: the dataset claims shape {tuple(shape)} ({nbytes} bytes) but stores "
                             f"{stored} bytes; not written or truncated, not read")
        return
    want = 1
    for n, c in zip(shape, ds.chunks):
        want *= -(-int(n) // int(c))
    try:
        have = ds.id.get_num_chunks()
    except (AttributeError, RuntimeError, OSError):  # (an HDF5 without the call: the frames are read)
        return
    if have < want:
        raise InputError(f"{where}: the dataset claims shape {tuple(shape)} but only {have} of its {want} chunks "
                         "are written (the rest would be fill values, not data); not read")


def _iter_h5(path: Path, dset: str | None) -> Iterator[np.ndarray]:
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"{path}: not a readable HDF5 file ({exc})") from None
    with f:
        try:  # (a damaged file: h5py raises KeyError/RuntimeError/OSError/ValueError from HDF5's internals)
            if dset is None:
                found = []
                f.visititems(lambda n, o: found.append(n) if isinstance(o, h5py.Dataset) and o.ndim in (2, 3) else None)
                if len(found) != 1:
                    raise InputError(f"{path}: holds {len(found)} image datasets; name one as {path}:/dataset")
                dset = found[0]
            if dset not in f or not isinstance(f[dset], h5py.Dataset):
                raise InputError(f"{path}: no dataset '{dset}'")
        except (KeyError, RuntimeError, OSError, ValueError, TypeError) as exc:
            raise InputError(f"{path}: a damaged HDF5 file ({_h5_reason(exc)})") from None
        try:
            _check_ndim(f[dset].shape, f"{path}:{dset}")
            _check_frame_size(f[dset].shape, f"{path}:{dset}")
            _check_written(f[dset], f"{path}:{dset}")
            _check_memory(f[dset].shape, f"{path}:{dset}")
            yield from _frames_of_array(f[dset], f"{path}:{dset}")
        except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
            raise InputError(f"{path}:{dset}: corrupt data ({_h5_reason(exc)})") from None


def _h5_reason(exc: BaseException) -> str:
    """HDF5's own words, without h5py's "Unable to synchronously ..." preamble."""
    text = str(exc).strip("'\"")
    return text[text.find("(") + 1:text.rfind(")")] if "(" in text and text.endswith(")") else text


def _iter_npy(path: Path) -> Iterator[np.ndarray]:
    """Frames of a ``.npy`` read one at a time from the file (not memory-mapped: a mapped
    stack's pages stay resident, so memory would grow with the stack)."""
    from numpy.lib import format as npf

    try:
        f = open(path, "rb")
    except OSError as exc:
        raise InputError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    with f:
        try:
            version = npf.read_magic(f)
            read_header = npf.read_array_header_1_0 if version == (1, 0) else npf.read_array_header_2_0
            shape, fortran, dtype = read_header(f)
        except Exception:  # any parse failure of untrusted bytes; numpy's text would echo them
            raise InputError(f"{path}: not a readable .npy file (no valid NumPy header)") from None
        _check_ndim(shape, str(path))
        if dtype.hasobject or (dtype.kind not in "uif" and dtype.kind != "b"):
            raise InputError(f"{path}: data of type {dtype} are not image data")
        _check_frame_size(shape, str(path))
        n, per = (shape[0] if len(shape) == 3 else 1), shape[-2] * shape[-1]
        have = (os.fstat(f.fileno()).st_size - f.tell()) // dtype.itemsize  # values the file holds
        if have < n * per:  # (said before allocating what the header claims)
            raise InputError(f"{path}: truncated: frame {have // per} of {n} is short ({have % per} of {per} values)")
        _check_memory(shape, str(path))
        if fortran and len(shape) == 3:
            raise InputError(f"{path}: a Fortran-ordered stack cannot be read frame by frame; save it in C order")
        rows, cols = shape[-2:]
        for i in range(shape[0] if len(shape) == 3 else 1):
            a = np.fromfile(f, dtype=dtype, count=rows * cols)
            if a.size != rows * cols:
                raise InputError(f"{path}: truncated: frame {i} of {shape[0] if len(shape) == 3 else 1} is short "
                                 f"({a.size} of {rows * cols} values)")
            yield _native(a.reshape((cols, rows)).T if fortran else a.reshape(rows, cols))


def _iter_npz_member(z, name: str, where: str) -> Iterator[np.ndarray]:
    """The frames of an .npz member read one at a time from the archive, as a .npy's are:
    its header checked first (frame size, memory, the data it claims against the member's
    size, the deflate ratio), never the whole array in memory."""
    from numpy.lib import format as npf

    member = name if name in z.zip.namelist() else name + ".npy"
    try:
        info = z.zip.getinfo(member)
        f = z.zip.open(member)
    except (KeyError, OSError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError) as exc:
        raise InputError(f"{where}: corrupt array ({exc})") from None
    with f:
        try:
            version = npf.read_magic(f)
            read_header = npf.read_array_header_1_0 if version == (1, 0) else npf.read_array_header_2_0
            shape, fortran, dtype = read_header(f)
            header = f.tell()
        except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:  # the archive's own check (CRC)
            raise InputError(f"{where}: corrupt array ({exc})") from None
        except Exception:  # any parse failure of untrusted bytes; numpy's text would echo them
            raise InputError(f"{where}: corrupt array (no valid NumPy header)") from None
        _check_ndim(shape, where)
        if dtype.hasobject or (dtype.kind not in "uif" and dtype.kind != "b"):
            raise InputError(f"{where}: data of type {dtype} are not image data")
        _check_frame_size(shape, where)
        _check_holds(shape, dtype, info.file_size - header, where)
        if info.compress_type != zipfile.ZIP_STORED and info.file_size > MAX_DEFLATE_RATIO * max(info.compress_size, 1):
            raise InputError(f"{where}: {info.compress_size} compressed bytes claim {info.file_size} bytes of data "
                             f"(more than {MAX_DEFLATE_RATIO} times: no image data compress so; a compression bomb?); "
                             "not read")
        _check_memory(shape, where)
        if fortran and len(shape) == 3:
            raise InputError(f"{where}: a Fortran-ordered stack cannot be read frame by frame; save it in C order")
        rows, cols = shape[-2:]
        n = shape[0] if len(shape) == 3 else 1
        for i in range(n):
            a = np.empty(rows * cols, dtype)
            try:
                got = f.readinto(a.view(np.uint8))
            except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
                raise InputError(f"{where}: corrupt array ({exc})") from None
            if got != a.nbytes:
                raise InputError(f"{where}: truncated: frame {i} of {n} is short")
            yield _native(a.reshape((cols, rows)).T if fortran else a.reshape(rows, cols))


def _iter_one(spec) -> Iterator[tuple[str | Path, np.ndarray]]:
    """(where each frame comes from: the file, or file:array; the frame) of one spec."""
    path, inner = split_spec(spec)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise InputError(f"{path}: folder holds no PNG/TIFF images")
        for p in files:
            yield p, read_image(p)
        return
    if not path.is_file():
        from ares.safefile import not_a_file

        raise not_a_file(path)
    suf = path.suffix.lower()
    if suf in IMAGE_SUFFIXES:
        yield path, read_image(path)
    elif suf == ".npy":
        yield from ((path, f) for f in _iter_npy(path))
    elif suf == ".npz":
        try:
            z = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError, zipfile.BadZipFile):
            raise InputError(f"{path}: not a readable .npz file (not a zip archive of .npy arrays)") from None
        if not z.files:
            z.close()
            raise InputError(f"{path}: the .npz archive holds no arrays")
        with z:
            names = [inner] if inner else list(z.files)
            for n in names:
                if n not in z.files:
                    raise InputError(f"{path}: no array '{n}' (has {', '.join(z.files)})")
                yield from ((f"{path}:{n}", f) for f in _iter_npz_member(z, n, f"{path}:{n}"))
    elif suf in _H5_SUFFIXES:
        yield from ((spec, f) for f in _iter_h5(path, inner))
    else:
        raise InputError(f"{path}: unknown stack format '{suf}' (use PNG/TIFF, .npy, .npz or .h5:/dataset)")


def iter_frames(specs: Sequence[str | Path]) -> Iterator[np.ndarray]:
    """Yield the 2-D frames of every spec in order, checking they share one shape and one
    data type (an 8-bit image among 16-bit ones is an export or another camera's frame,
    not one of this stack's)."""
    if isinstance(specs, (str, Path)):
        specs = [specs]
    if not specs:
        raise InputError("no stack files given")
    shape = dtype = first = None
    for spec in specs:
        for where, frame in _iter_one(spec):
            if shape is None:
                shape, dtype, first = frame.shape, frame.dtype, where
            elif frame.shape != shape:
                raise InputError(f"{where}: frame shape {frame.shape} differs from {shape} of {first}")
            elif frame.dtype != dtype:
                raise InputError(f"{where}: {frame.dtype} data among the {dtype} frames of {first}; "
                                 "a stack's frames share one data type")
            yield frame


def stack_shape(specs) -> tuple[int, int]:
    """Frame shape (rows, cols) of the first frame."""
    for f in iter_frames(specs):
        return tuple(f.shape)
    raise InputError("the stack holds no frames")


def load_stack(specs) -> np.ndarray:
    """All frames as one 3-D array (for small stacks and tests)."""
    frames = list(iter_frames(specs))
    if not frames:
        raise InputError("the stack holds no frames")
    return np.stack(frames)
