"""Finished stages analysed and committed beside the next stage's acquisition.

A stage's analysis (the 13-component decomposition of each view, the gain, the maps)
and its commit to the run directory (``stages/NNNN.h5`` + ``.json``) take about as long
as acquiring it on the simulator; done in a second thread they overlap the next stage's
frames, on the second core wherever numpy, the fused simulator kernels and zlib release
the GIL. One stage at a time and in order: ``submit`` first waits for the stage before
(so at most two stacks' accumulators live at once), and the results, files and events
are exactly those of the one-thread run.

Errors travel to the acquiring thread: ``submit``/``wait`` re-raise what the previous
commit raised (a full disk stops the scan at the next stage boundary, with every
committed stage kept); ``settle`` waits without raising, for a run that is already
ending on another error (the first error is the one reported).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable

log = logging.getLogger(__name__)


class StageCommitter:
    def __init__(self, fn: Callable[..., None], threaded: bool = True):
        self._fn = fn
        self.threaded = threaded
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        # the CPU time of the thread that did the latest finished commit: what the run waits
        # for the last stage's, which has the cores to itself (its wall time beside the next
        # stage's frames is no guide: 91-109 ms for 54 ms of CPU on make run; the last one,
        # alone, 55 ms)
        self.cpu_seconds: float | None = None

    def submit(self, *args) -> None:
        """Analyse and commit a stage: in the worker thread, after the previous one."""
        self.submit_fn(self._fn, *args)

    def submit_fn(self, fn: Callable[..., None], *args) -> None:
        """Run ``fn(*args)`` in the worker thread after the previous work (e.g. rewriting
        the stages a completed defect mask changes, ares.scan.mask_complete)."""
        self.wait()
        if not self.threaded:
            self._timed(fn, *args)
            return
        self._thread = threading.Thread(target=self._work, args=(fn, *args), name="ares-stage-commit", daemon=True)
        self._thread.start()

    def _timed(self, fn, *args) -> None:
        c0 = time.thread_time()
        fn(*args)
        self.cpu_seconds = time.thread_time() - c0

    def _work(self, fn, *args) -> None:
        try:
            self._timed(fn, *args)
        except BaseException as exc:  # noqa: BLE001 -- handed to the acquiring thread
            self._error = exc

    def check(self) -> None:
        """Raise now if the stage in flight has already failed (no waiting)."""
        if self._thread is not None and not self._thread.is_alive():
            self.wait()

    def wait(self) -> None:
        """Wait for the stage in flight; re-raise its error."""
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._error is not None:
            exc, self._error = self._error, None
            raise exc

    def settle(self) -> None:
        """Wait for the stage in flight; its error (if any) is logged, not raised."""
        try:
            self.wait()
        except BaseException as exc:  # noqa: BLE001
            log.warning("stage commit failed while the run was ending on another error: %s", exc)
