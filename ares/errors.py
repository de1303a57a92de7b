"""Errors a user can cause, each with the exit code the CLI returns for it.

Every error carries one plain sentence that names the file/line or the device; the CLI
prints ``str(error)`` and exits with ``error.exit_code`` -- never a traceback.
"""


class AresError(Exception):
    """Base of all errors that the CLI reports as one sentence."""

    exit_code = 1


class InputError(AresError):
    """Invalid input: malformed XML, bad value, unknown register, missing file."""

    exit_code = 2


class HardwareError(AresError):
    """A device failed: gone, timed out, returned a short or corrupt frame."""

    exit_code = 3


class StorageError(AresError):
    """The run directory cannot be written: disk full, read-only, quota, permission."""

    exit_code = 5


class LimitsFailed(AresError):
    """A scan finished but one or more pass/fail limits failed."""

    exit_code = 4


class Interrupted(AresError):
    """The user stopped or aborted the run (completed stages are kept)."""

    exit_code = 130


class UnknownRegister(InputError):
    """A register field name that the register map does not declare."""


class ValueOutOfRange(InputError):
    """A value outside a field's declared limits or bit width."""


class DeviceGone(HardwareError):
    """A device stopped answering (unplugged, bus error). ``device`` names the bench part
    that failed ("frames", "registers", "light", "chamber"), so a recovery reconnects that
    one and not another."""

    def __init__(self, message: str = "", device: str = "frames"):
        super().__init__(message)
        self.device = device


class FrameError(HardwareError):
    """A frame was short, of the wrong shape, or corrupt."""


class FrameLost(FrameError):
    """Frames did not arrive whole: ``kind`` is "dropped" (a gap in the device's frame
    counter), "corrupt" (CRC or header mismatch) or "short" (the transfer ended early).
    A scan may re-grab the stage (``<frames on_loss="regrab">``) instead of failing."""

    def __init__(self, message: str, kind: str = "dropped", count: int = 1):
        super().__init__(message)
        self.kind, self.count = kind, count


def interruption(exc: BaseException | None) -> BaseException | None:
    """The interruption behind ``exc``: ``exc`` itself when it is one (a signal's exception:
    ``KeyboardInterrupt``, the CLI's ``ReportsAbandoned`` -- a ``BaseException`` that is no
    ``Exception``), else the one it replaced on its way out. A signal cuts a library's work
    short; its cleanup on the way out (a ``with`` block's ``__exit__``, a ``finally``) may
    then fail with an error of its own that carries the signal's only as ``__context__``
    (matplotlib's PdfPages flushing a zlib stream the signal had finished: ``zlib.error``),
    or carry it as its cause (a C extension's module init that the signal cut short:
    ``ImportError: initialization failed``). None when no interruption is in the chain."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if not isinstance(exc, (Exception, GeneratorExit)):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None
