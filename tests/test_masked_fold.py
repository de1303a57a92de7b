"""The one-pass masked fold (numba) equals the numpy fold bit for bit."""

import numpy as np
import pytest

from ares.analysis import masked_fold
from ares.analysis.masked import MaskedStackAccumulator

pytest.importorskip("numba")


def _state(acc):
    return (acc._s1, acc._s2, acc._r2, acc._c2, np.array(acc._t2), np.concatenate(acc._tot), np.array(acc._nf))


@pytest.mark.parametrize("dtype,batch", [(np.uint16, 1), (np.uint16, 8), (np.int16, 3), (np.uint8, 8)])
def test_numba_fold_equals_numpy(monkeypatch, dtype, batch):
    rng = np.random.default_rng(7)
    shape = (37, 53)
    mask = rng.random(shape) < 0.05
    mask[3] = True  # a whole bad row
    info = np.iinfo(dtype)
    frames = rng.integers(max(info.min, -3000), min(info.max, 60000), size=(19,) + shape).astype(dtype)
    fast = MaskedStackAccumulator(shape, mask, batch=batch)
    fast.add(frames[0])
    fast.add_batch(frames[1:])  # blocks of ``batch`` frames
    assert masked_fold.fold(frames[:1], fast._x0, fast.good, fast._s1.copy(), fast._s2.copy()) is not None
    monkeypatch.setattr(masked_fold, "_kernel_c", None)
    monkeypatch.setattr(masked_fold, "_loaded", True)
    slow = MaskedStackAccumulator(shape, mask, batch=batch)
    slow.add(frames[0])
    slow.add_batch(frames[1:])
    for a, b in zip(_state(fast), _state(slow)):
        np.testing.assert_array_equal(a, b)
    assert fast.decompose_dark()["Pt"].value == slow.decompose_dark()["Pt"].value


def test_float_frames_take_the_numpy_fold():
    x = np.zeros((1, 4, 4), np.float32)
    assert masked_fold.fold(x, np.zeros((4, 4)), np.ones((4, 4), bool), np.zeros((4, 4)), np.zeros((4, 4))) is None
