"""Work around a PySide6 reference-count bug seen with PySide6 6.12 on CPython 3.11.

That build returns ``True``/``False``/``None`` from some calls without taking a
reference (measured: every ``Signal.emit()`` drops one reference to ``True``; every
``processEvents()``, ``deleteLater()`` and Python slot call drops one to ``None``).
pyqtgraph emits signals on every redraw, so after a few thousand redraws the interpreter
aborts with "Fatal Python error: bool_dealloc" / "none_dealloc". CPython 3.12+ makes
these singletons immortal, which hides the bug there.

``apply()`` detects the bug (ten emissions, refcount of ``True`` before/after) and, only
if it is present, raises the three singletons' refcounts by a margin that no session
can use up.
"""

from __future__ import annotations

import ctypes
import sys

_MARGIN = 1 << 40
_applied = False


def bug_present() -> bool:
    from PySide6.QtCore import QObject, Signal

    class _Probe(QObject):
        sig = Signal(object)

    probe = _Probe()
    probe.sig.connect(lambda _value: None)
    before = sys.getrefcount(True)
    for _ in range(10):
        probe.sig.emit(True)
    return sys.getrefcount(True) < before - 5


def apply() -> bool:
    """Install the workaround if needed; True if it was installed (now or before)."""
    global _applied
    if _applied:
        return True
    if sys.version_info >= (3, 12) or sys.implementation.name != "cpython":
        return False
    if not bug_present():
        return False
    for obj in (True, False, None):
        ctypes.c_ssize_t.from_address(id(obj)).value += _MARGIN
    _applied = True
    return True


apply()
