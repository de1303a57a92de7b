"""The frames of the stage a defect mask is built from, kept to mask that stage too
(``StackSet.kept``): in memory up to a byte budget, the rest in an unnamed temporary file
beside the run (deleted when closed, or by the system when the process ends), read back
once in order. A 4096x3072 dark stage of 32 frames (768 MiB) keeps 256 MiB in memory and
is masked like any other stage; before, a stage over the budget went unmasked."""

from __future__ import annotations

import tempfile

import numpy as np

from ares.errors import StorageError


class KeptFrames:
    def __init__(self, budget: int, directory=None):
        self.budget = int(budget)
        self.directory = directory
        self._mem: list[np.ndarray] = []
        self._bytes = 0
        self._file = None
        self._spilled: list[tuple[tuple, np.dtype]] = []  # (shape, dtype) of each frame in the file

    def __len__(self) -> int:
        return len(self._mem) + len(self._spilled)

    @property
    def in_memory(self) -> int:
        """Bytes of frames held in memory (the rest is in the file)."""
        return self._bytes

    @property
    def spilled(self) -> int:
        return len(self._spilled)

    def append(self, frame: np.ndarray) -> None:
        a = np.ascontiguousarray(frame)
        if self._file is None and self._bytes + a.nbytes <= self.budget:
            self._mem.append(np.array(a, copy=True))
            self._bytes += a.nbytes
            return
        where = self.directory or tempfile.gettempdir()
        try:
            if self._file is None:
                self._file = tempfile.TemporaryFile(dir=self.directory, prefix=".ares-kept-")
            self._file.write(memoryview(a).cast("B"))
        except OSError as exc:
            self.close()
            raise StorageError(f"{where}: cannot keep the dark stage's frames for the defect mask "
                               f"({exc.strerror or exc})") from None
        self._spilled.append((a.shape, a.dtype))

    def __iter__(self):
        yield from self._mem
        if self._file is None:
            return
        self._file.flush()
        self._file.seek(0)
        for shape, dtype in self._spilled:
            out = np.empty(shape, dtype)
            n = self._file.readinto(memoryview(out).cast("B"))
            if n != out.nbytes:
                raise StorageError(f"{self.directory or tempfile.gettempdir()}: the kept dark frames were cut short "
                                   f"({n} of {out.nbytes} bytes read back)")
            yield out

    def close(self) -> None:
        self._mem = []
        if self._file is not None:
            self._file.close()
            self._file = None
