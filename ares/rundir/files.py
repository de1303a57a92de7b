"""Files of a run directory written safely: atomic replace with fsync, JSON with hashes, the folder claimed exclusively, the storage errors named."""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import sys
from contextlib import contextmanager
from pathlib import Path
import numpy as np
from ares.errors import InputError, StorageError
from ares.rundir.state import is_storage_error, storage_sentence


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def versions() -> dict:
    import importlib.metadata as md

    out = {"python": sys.version.split()[0], "platform": platform.platform()}
    for pkg in ("ares", "numpy", "scipy", "lxml", "h5py", "pyserial", "pyusb", "smbus2"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            out[pkg] = None
    from ares import __version__

    out["ares_source"] = __version__
    return out


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON-able: {type(o).__name__}")


def _clean(o):
    """NaN/inf -> None so the JSON is strict."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    return o


@contextmanager
def storage(path):
    """Disk full, read-only, quota, permission while writing ``path``: one sentence
    (``StorageError``), and the temporary file of an atomic write is not left behind."""
    try:
        yield
    except (OSError, RuntimeError) as exc:  # (h5py wraps a failed write in a RuntimeError)
        if is_storage_error(exc):
            raise StorageError(storage_sentence(exc, path)) from None
        raise


def write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def _fsync(path: Path) -> None:
    with open(path, "rb+") as fh:
        os.fsync(fh.fileno())


def json_bytes(obj) -> bytes:
    """``obj`` as the strict JSON bytes ``dump_json`` writes."""
    return json.dumps(_clean(obj), indent=1, default=_json_default, allow_nan=False).encode()


def dump_json(path: Path, obj) -> str:
    """Write ``obj`` as strict JSON (atomically); the SHA-256 of the bytes written."""
    data = json_bytes(obj)
    write_atomic(path, data)
    return sha256(data)


CLAIM = ".ares-claim"


def claim_run_dir(d: Path) -> None:
    """Make ``d`` this process's run directory, exclusively: a new directory, or an empty
    one (or one this process claimed before). Two runs given the same --out can never
    write into, or nest inside, the same folder."""
    try:
        try:
            d.parent.mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            bad = next((a for a in [d.parent, *d.parent.parents] if a.exists() and not a.is_dir()), d.parent)
            raise InputError(f"{d}: cannot create the run directory ({bad} is not a directory)") from None
        try:
            d.mkdir()
        except FileExistsError:
            if not d.is_dir():
                raise InputError(f"{d}: exists and is not a directory") from None
            mine = (d / CLAIM).is_file() and (d / CLAIM).read_text().strip() == str(os.getpid())
            others = [p.name for p in d.iterdir() if p.name != CLAIM]
            if others or ((d / CLAIM).exists() and not mine):
                raise InputError(f"{d}: output directory exists and is not empty") from None
            if mine:
                return
        fd = os.open(d / CLAIM, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
    except FileExistsError:
        raise InputError(f"{d}: being written by another run") from None
    except OSError as exc:
        if is_storage_error(exc):
            raise StorageError(storage_sentence(exc, d)) from None
        raise InputError(f"{d}: cannot create the run directory ({exc.strerror or exc})") from None
