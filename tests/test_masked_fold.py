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


@pytest.mark.parametrize("dtype", [np.uint16, np.int16, np.uint8])
def test_line_sums_of_a_derived_stack_equal_numpy(monkeypatch, dtype):
    """A masked stack fed beside its full-frame stack keeps only line sums: the lines kernel
    (every pixel, less the masked ones and the shift) equals the numpy fold bit for bit."""
    from ares.analysis.accumulate import StackAccumulator

    rng = np.random.default_rng(11)
    shape = (29, 41)
    mask = rng.random(shape) < 0.07
    mask[:, 5] = True  # a whole bad column
    info = np.iinfo(dtype)
    frames = rng.integers(max(info.min, -3000), min(info.max, 60000), size=(13,) + shape).astype(dtype)

    def run():
        full = StackAccumulator(shape)
        acc = MaskedStackAccumulator(shape, mask, batch=4, pixels=full)
        for f in frames:
            full.add(f)
            acc.add(f)
        return acc

    fast = run()
    assert fast._derived and fast._plan is not None  # the lines kernel was the one used
    monkeypatch.setattr(masked_fold, "_lines_c", None)
    monkeypatch.setattr(masked_fold, "_lines_loaded", True)
    monkeypatch.setattr(masked_fold, "_kernel_c", None)
    monkeypatch.setattr(masked_fold, "_loaded", True)
    slow = run()
    for a, b in zip((fast._r2, fast._c2, np.array(fast._t2), np.concatenate(fast._tot), *fast._sums()),
                    (slow._r2, slow._c2, np.array(slow._t2), np.concatenate(slow._tot), *slow._sums())):
        np.testing.assert_array_equal(a, b)
    assert fast.decompose_dark()["Pt"].value == slow.decompose_dark()["Pt"].value


def test_float_frames_take_the_numpy_fold():
    x = np.zeros((1, 4, 4), np.float32)
    assert masked_fold.fold(x, np.zeros((4, 4)), np.ones((4, 4), bool), np.zeros((4, 4)), np.zeros((4, 4))) is None


@pytest.mark.parametrize("derived", [True, False])
def test_kept_accessor_results_equal_fresh_ones_and_follow_new_frames(monkeypatch, derived):
    """The masked stack keeps its sums, mean map, pixel SS and forms between calls (a
    stage's analysis asks for each several times): the same numbers as computed afresh,
    read-only, and recomputed once more frames arrive."""
    import ares.analysis.masked as M
    from ares.analysis.accumulate import StackAccumulator

    rng = np.random.default_rng(3)
    shape = (24, 32)
    mask = rng.random(shape) < 0.05
    frames = rng.integers(100, 4000, size=(12,) + shape).astype(np.uint16)

    def stack(n):
        full = StackAccumulator(shape) if derived else None
        acc = MaskedStackAccumulator(shape, mask, pixels=full)
        for f in frames[:n]:
            if full is not None:
                full.add(f)
            acc.add(f)
        return acc

    kept = stack(8)
    assert kept._derived == derived
    first = (kept.mean_map(), kept.pixel_ss(), kept.temporal_forms(), kept.mean())
    assert kept.mean_map() is first[0] and not first[0].flags.writeable  # kept, and read-only
    monkeypatch.setattr(M, "MEMO_MAX_PIXELS", 0)  # nothing kept: every call computes afresh
    fresh = stack(8)
    np.testing.assert_array_equal(first[0], fresh.mean_map())
    np.testing.assert_array_equal(first[1], fresh.pixel_ss())
    assert first[2] == fresh.temporal_forms() and first[3] == fresh.mean()
    assert fresh.decompose_dark()["Pt"].value == kept.decompose_dark()["Pt"].value
    monkeypatch.undo()
    if derived:
        kept._pixels.add_batch(frames[8:])
    kept.add_batch(frames[8:])  # more frames: the kept results are stale and recomputed
    grown = stack(12)
    np.testing.assert_array_equal(kept.mean_map(), grown.mean_map())
    assert kept.temporal_forms() == grown.temporal_forms()
