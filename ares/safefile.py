"""Reading a file a user named, safely: one place for every reader of user input.

Only regular files are read (a FIFO would hang, /dev/zero would fill the memory), the
size is checked before reading, and error sentences name the file but never echo its
content. ``confine`` keeps paths that a descriptor or recording references inside the
directories the user named, or says which path escapes.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from ares.errors import InputError


def check_regular(path: str | Path, max_bytes: int, what: str = "file") -> int:
    """The size of ``path`` after checking that it is a regular file no larger than
    ``max_bytes``; one sentence otherwise."""
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise InputError(f"{p}: {what} not found") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read the {what} ({exc.strerror or type(exc).__name__})") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{p}: is a directory, not a {what}")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{p}: not a regular file (a device, FIFO or socket); ARES reads {what}s from regular files")
    if st.st_size > max_bytes:
        raise InputError(f"{p}: {st.st_size} bytes is larger than a {what} can be ({max_bytes} bytes)")
    return st.st_size


def read_regular(path: str | Path, max_bytes: int, what: str = "file") -> bytes:
    """The bytes of a regular file of at most ``max_bytes`` (checked before reading)."""
    check_regular(path, max_bytes, what)
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the {what} ({exc.strerror or type(exc).__name__})") from None
    if len(data) > max_bytes:  # grew while we looked
        raise InputError(f"{path}: larger than a {what} can be ({max_bytes} bytes)")
    return data


def confine(path: Path, roots: list[Path], where: str) -> Path:
    """``path`` resolved, if it lies inside one of ``roots``; else one sentence naming
    ``where`` it was referenced and the path (never the file's content)."""
    rp = Path(os.path.realpath(path))
    for r in roots:
        rr = Path(os.path.realpath(r))
        if rp == rr or rr in rp.parents:
            return rp
    link = f" (a link to {rp})" if _through_link(Path(os.path.abspath(path)), roots) else ""
    raise InputError(f"{where}: references {path}{link}, outside the data directory "
                     f"{', '.join(str(r) for r in roots)}; ARES reads only files below it")


def _through_link(path: Path, roots: list[Path]) -> bool:
    """Whether ``path`` or a folder of it below the root it is written under is a symbolic link."""
    for q in (path, *path.parents):
        if not any(Path(os.path.abspath(r)) in q.parents for r in roots):
            return False  # at or above the root, or never below it
        if q.is_symlink():
            return True
    return False
