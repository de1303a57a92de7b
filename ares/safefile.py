"""Reading a file a user named, safely: one place for every reader of user input.

Only regular files are read (a FIFO would hang, /dev/zero would fill the memory), the
size is checked before reading, and error sentences name the file but never echo its
content. ``Confinement`` keeps paths that a descriptor or recording references inside the
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


def not_a_file(path: str | Path, what: str = "file") -> InputError:
    """The sentence for a path that is not a readable regular file: missing, a directory,
    or a device/FIFO/socket (``/dev/zero``, a pipe) -- never "not found" for those."""
    p = Path(path)
    if p.is_dir():
        return InputError(f"{p}: is a directory, not a {what}")
    if os.path.lexists(p) and p.exists():
        return InputError(f"{p}: not a regular file (a device, FIFO or socket); ARES reads {what}s from regular files")
    return InputError(f"{p}: {what} not found")


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


class Confinement:
    """Paths are accepted only inside ``roots`` (resolved once): calling it with a path gives
    the path resolved, or one sentence naming ``where`` it was referenced and the path
    (never the file's content). The folders of many files are resolved once each: a file
    that is not itself a link resolves to its resolved folder plus its name (an EMVA data
    set's 300 images: 4 ms instead of 30)."""

    def __init__(self, roots: list[Path]):
        self.roots = roots
        self._real_roots = [os.path.realpath(r) for r in roots]
        self._folders: dict[str, str] = {}

    def _resolve(self, path: Path) -> str:
        folder, name = os.path.split(os.fspath(path))
        if name in ("", ".", "..") or os.path.islink(path):
            return os.path.realpath(path)
        real = self._folders.get(folder)
        if real is None:
            real = self._folders[folder] = os.path.realpath(folder or ".")
        return os.path.join(real, name)

    def __call__(self, path: Path, where: str) -> Path:
        rp = self._resolve(path)
        for rr in self._real_roots:
            if rp == rr or rp.startswith(rr.rstrip(os.sep) + os.sep):
                return Path(rp)
        link = f" (a link to {rp})" if _through_link(Path(os.path.abspath(path)), self.roots) else ""
        raise InputError(f"{where}: references {path}{link}, outside the data directory "
                         f"{', '.join(str(r) for r in self.roots)}; ARES reads only files below it")


def _through_link(path: Path, roots: list[Path]) -> bool:
    """Whether ``path`` or a folder of it below the root it is written under is a symbolic link."""
    for q in (path, *path.parents):
        if not any(Path(os.path.abspath(r)) in q.parents for r in roots):
            return False  # at or above the root, or never below it
        if q.is_symlink():
            return True
    return False
