"""Reading and writing a file a user named, safely: one place for every reader of user
input and every writer of a command's output.

Only regular files are read (a FIFO would hang, /dev/zero would fill the memory), the
size is checked before reading, and error sentences name the file but never echo its
content. ``Confinement`` keeps paths that a descriptor or recording references inside the
directories the user named, or says which path escapes.

The output guard (``output_file``, ``output_folder``, ``writing``): every file a command
writes goes through the checks and errors ``ares run`` uses for its run directory -- the
folder exists (or is created, for a folder option), is a folder, is writable, has the
space -- before the work where possible; what the disk refuses during the write (full,
read-only, quota; also when a library raises its own error over it: ``zlib.error`` from a
PDF stream, h5py's ``RuntimeError``) is one sentence naming the file, exit 5; a path that
cannot be an output (a folder where a file goes, a file where a folder goes) exit 2.
"""

from __future__ import annotations

import errno
import os
import stat
from contextlib import contextmanager
from pathlib import Path

from ares.errors import AresError, InputError, StorageError

STORAGE_ERRNOS = {
    errno.ENOSPC: "the disk is full",
    errno.EFBIG: "the file is larger than the file-size limit (ulimit -f) or the file system allows",
    errno.EDQUOT: "the disk quota is exceeded",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EIO: "an input/output error",
    errno.ENOENT: "the directory does not exist (or disappeared)",
    errno.ENOTDIR: "a folder of the path is a file",
    errno.EISDIR: "the path is a directory",
    errno.EMFILE: "too many files are open",
    errno.ENFILE: "too many files are open on the system",
    errno.ENAMETOOLONG: "the file name is too long",
    errno.ESTALE: "the network file system lost the file (stale handle)",
    errno.ENXIO: "the device is gone",
    errno.ENODEV: "the device is gone",
}


def os_errno(exc: BaseException) -> int | None:
    """The errno of an OS error, also when a library wraps it in its message only
    (h5py/HDF5 raise OSError or RuntimeError "... file write failed: ... filename = 'x',
    ... errno = 27, error message = 'File too large' ...")."""
    if isinstance(exc, OSError) and exc.errno is not None:
        return exc.errno
    if not isinstance(exc, (OSError, RuntimeError)):
        return None
    import re

    m = re.search(r"errno = (\d+)", str(exc))
    return int(m.group(1)) if m else None


def storage_sentence(exc: BaseException, path) -> str:
    """One sentence: the file (the error's own when it names one) and what the disk said."""
    import re

    code = os_errno(exc)
    why = STORAGE_ERRNOS.get(code, getattr(exc, "strerror", None) or type(exc).__name__)
    named = getattr(exc, "filename", None)
    if named is None:
        m = re.search(r"filename = '([^']*)'", str(exc))
        named = m.group(1) if m else None
    return f"cannot write {named or path}: {why}"


def is_storage_error(exc: BaseException) -> bool:
    return os_errno(exc) in STORAGE_ERRNOS


def machine_memory() -> tuple[float | None, float | None]:
    """(total, available) physical memory in bytes, from /proc/meminfo or sysconf."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            info = {ln.split(":")[0]: float(ln.split()[1]) * 1024 for ln in f if ":" in ln}
        return info.get("MemTotal"), info.get("MemAvailable")
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")), None
    except (ValueError, OSError, AttributeError):
        return None, None


def check_memory(need_bytes: float, where: str, what: str) -> None:
    """Before allocating: ``need_bytes`` (``what`` takes them, e.g. "analysing 12000x12000
    frames") fit the memory this machine has available; one sentence naming ``where`` otherwise."""
    total, avail = machine_memory()
    have = avail if avail is not None else total
    if have is not None and need_bytes > have:
        raise InputError(f"{where}: {what} takes about {need_bytes / 2**30:.1f} GiB of memory, more than the "
                         f"{have / 2**30:.1f} GiB this machine has available; not read")


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


# ------------------------------------------------------------------ the output guard


def _parent(p: Path) -> Path:
    return p.parent if str(p.parent) else Path(".")


def _writable_folder(folder: Path, option: str, need_bytes: float) -> None:
    """``folder`` exists: a folder this process may create files in, with ``need_bytes`` free."""
    import shutil

    if not folder.is_dir():
        raise InputError(f"{option} {folder}: is not a folder")
    need_bytes = MIN_FREE_BYTES if need_bytes is None else need_bytes
    if not os.access(folder, os.W_OK | os.X_OK):
        code = errno.EROFS if _read_only_fs(folder) else errno.EACCES
        raise StorageError(f"cannot write in {folder}: {STORAGE_ERRNOS[code]}")
    if need_bytes > 0:
        try:
            free = shutil.disk_usage(folder).free
        except OSError:
            return
        if need_bytes > free:
            raise StorageError(f"cannot write in {folder}: about {need_bytes / 1e6:.1f} MB are needed and "
                               f"{free / 1e6:.1f} MB are free")


def _read_only_fs(folder: Path) -> bool:
    try:
        return bool(os.statvfs(folder).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):
        return False


MIN_FREE_BYTES = 1e6  # an output of unknown size: at least this much free (a full disk is refused before the work)


def output_file(path: str | Path, option: str, need_bytes: float | None = None) -> Path:
    """Before the work: ``path`` can be written as a file (``option`` names it in the
    sentence, e.g. ``--pdf``). Its folder must exist (a missing folder is a mistyped
    argument: exit 2), be a folder and be writable with ``need_bytes`` free (exit 5);
    ``path`` itself must not be a folder (exit 2)."""
    p = Path(path)
    if not str(path).strip():
        raise InputError(f"{option}: the file name must not be empty")
    if p.is_dir():
        raise InputError(f"{option} {p}: is a folder; name the file to write")
    if p.exists() and not p.is_file():
        raise InputError(f"{option} {p}: not a regular file (a device, FIFO or socket); name a file to write")
    folder = _parent(p)
    if not folder.exists():
        raise InputError(f"{option} {p}: the folder {folder} does not exist")
    _writable_folder(folder, option, need_bytes)
    if p.exists() and not os.access(p, os.W_OK):
        raise StorageError(f"cannot write {p}: {STORAGE_ERRNOS[errno.EACCES]}")
    return p


def output_folder(path: str | Path, option: str, need_bytes: float | None = None) -> Path:
    """Before the work: ``path`` can hold a command's files (created, with its parents,
    when missing, as ``ares run --out`` does); a file there is exit 2, a folder that
    cannot be written or lacks ``need_bytes`` exit 5."""
    p = Path(path)
    if not str(path).strip():
        raise InputError(f"{option}: the folder name must not be empty")
    if p.exists() and not p.is_dir():
        raise InputError(f"{option} {p}: exists and is not a folder")
    if not p.exists():
        bad = next((a for a in p.parents if a.exists() and not a.is_dir()), None)
        if bad is not None:
            raise InputError(f"{option} {p}: cannot create the folder ({bad} is not a folder)")
        _writable_folder(next(a for a in p.absolute().parents if a.exists()), option, need_bytes)
        try:
            p.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise storage_error(exc, p) or InputError(f"{option} {p}: cannot create the folder "
                                                      f"({exc.strerror or exc})") from None
    _writable_folder(p, option, need_bytes)
    return p


# errnos that only a write can meet: what the CLI turns into one sentence for any command
# (a missing or unreadable *input* keeps its reader's own sentence)
WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG)


def storage_error(exc: BaseException, path, codes=None) -> AresError | None:
    """The one-sentence error behind ``exc`` raised while writing ``path``: a storage errno
    anywhere in its chain (a library's cleanup raising over the disk's error, as
    matplotlib's PDF stream does with ``zlib.error``) -> ``StorageError``; a path that is a
    folder or through a file -> ``InputError``; else None (a real bug keeps its traceback)."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        code = os_errno(e)
        if codes is not None:
            if code in codes:
                return StorageError(storage_sentence(e, path))
        elif code in (errno.EISDIR, errno.ENOTDIR):
            return InputError(storage_sentence(e, path))
        if code in STORAGE_ERRNOS:
            return StorageError(storage_sentence(e, path))
        e = e.__cause__ or e.__context__
    return None


@contextmanager
def writing(path: str | Path, keep_partial: bool = False):
    """Write ``path`` inside: what the disk refuses becomes one sentence (``storage_error``)
    and the partial file is removed (a half-written file is never left to be read as whole),
    unless ``keep_partial``."""
    p = Path(path) if path else None  # (None: standard output, no file to clean)
    existed = p is None or p.exists()
    try:
        yield p
    except AresError:
        raise
    except Exception as exc:  # noqa: BLE001 -- a storage errno anywhere in its chain, or re-raised as it is
        err = storage_error(exc, p or "standard output")
        if err is None:
            raise
        for q in ([] if keep_partial or existed else [p]) + ([p.with_name(p.name + ".tmp")] if p else []):
            try:
                if q.is_file():
                    q.unlink()
            except OSError:
                pass
        if p is not None:  # the file the user named, not its temporary name
            err = type(err)(str(err).replace(f"{p}.tmp", str(p)))
        raise err from None
