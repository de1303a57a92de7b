"""The dark stage a defect mask is built from keeps its frames to be masked too
(``ares.scan.kept``): in memory up to a budget, the rest in a temporary file -- the same
frames back in order, the same run either way, and a full disk is one clear error."""

from __future__ import annotations

import errno
import json
import tempfile
from pathlib import Path

import numpy as np
import pytest

import ares.scan.stage_loop as stage_loop_mod
from ares.errors import StorageError
from ares.protocol import load_scan
from ares.scan import Runner
from ares.scan.kept import KeptFrames
from run_files import stage_results

SMALL = Path(__file__).resolve().parents[1] / "fixtures" / "xml" / "small"


@pytest.mark.parametrize("dtype", [np.uint16, np.uint8])
def test_frames_come_back_in_order_from_memory_and_file(tmp_path, dtype):
    rng = np.random.default_rng(2)
    frames = [rng.integers(0, np.iinfo(dtype).max, size=(12, 17), dtype=dtype) for _ in range(5)]
    k = KeptFrames(budget=2 * frames[0].nbytes, directory=tmp_path)
    for f in frames:
        k.append(f[:, :])
    assert len(k) == 5 and k.spilled == 3
    assert list(tmp_path.iterdir()) == []  # an unnamed file: nothing to clean up after a crash
    back = list(k)
    for a, b in zip(frames, back):
        assert b.dtype == a.dtype
        np.testing.assert_array_equal(a, b)
    frames[0][:] = 0  # copies were kept, not the caller's buffers
    assert next(iter(k)).any()
    k.close()


def test_a_full_disk_is_one_sentence_naming_the_directory(tmp_path, monkeypatch):
    class Full:
        def write(self, b):
            raise OSError(errno.ENOSPC, "No space left on device")

        def close(self):
            pass

    monkeypatch.setattr(tempfile, "TemporaryFile", lambda **kw: Full())
    k = KeptFrames(budget=0, directory=tmp_path)
    with pytest.raises(StorageError, match=rf"^{tmp_path}: cannot keep the dark stage's frames .*No space left"):
        k.append(np.zeros((4, 4), np.uint16))


def test_a_dark_stage_over_the_memory_budget_is_masked_the_same(tmp_path, monkeypatch):
    import dataclasses

    sc = load_scan(SMALL / "ptc_small.xml")
    sc = dataclasses.replace(sc, output=dataclasses.replace(sc.output, pdf=False))  # (stage results compared)
    a = Runner(sc, out_dir=tmp_path / "memory", seed=3).run()
    spilled = []
    real = KeptFrames.append
    monkeypatch.setattr(stage_loop_mod, "KEEP_FOR_MASK_BYTES", 0)  # every frame to the file
    monkeypatch.setattr(KeptFrames, "append", lambda self, f: (real(self, f), spilled.append((id(self), self.spilled))))
    b = Runner(sc, out_dir=tmp_path / "file", seed=3).run()
    assert a.status == b.status == "done"
    # every frame of every stack kept (the dark's, and the provisional stages' until a flat completes
    # the mask) went to the file
    per = {}
    for k, n in spilled:
        per[k] = per.get(k, 0) + 1
        assert n == per[k]
    assert spilled
    ra, rb = stage_results(tmp_path / "memory"), stage_results(tmp_path / "file")
    assert "components_masked" in json.dumps(ra[0])  # the dark stage itself is masked
    assert json.dumps(ra, sort_keys=True) == json.dumps(rb, sort_keys=True)
