"""The one-pass masked fold (numba) equals the numpy fold bit for bit."""

import numpy as np
import pytest

from ares.analysis.kernels import masked_fold
from ares.analysis.noise.masked import MaskedStackAccumulator

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
    from ares.analysis.noise.accumulate import StackAccumulator

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
    import ares.analysis.noise.masked as M
    from ares.analysis.noise.accumulate import StackAccumulator

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


@pytest.mark.parametrize("dtype", [np.uint16, np.int16, np.uint8])
@pytest.mark.parametrize("int_kernel", ["numba", "numpy"])
def test_a_stack_riding_on_its_full_frame_folds_equals_one_fed_frames(monkeypatch, dtype, int_kernel):
    """``ride``: the masked stack's line sums from its full-frame stack's folds (exact int64
    row/column sums less the masked pixels and the shift) equal those of a masked stack fed
    every frame, bit for bit: frames copied into the batch store (uint16 held as x ^ 0x8000)
    and read-only frames kept uncopied, on either integer kernel, a read in the middle of a
    batch, and frames of another kind after it (``unride``)."""
    from ares.analysis.kernels import int_fold
    from ares.analysis.noise.accumulate import StackAccumulator

    if int_kernel == "numpy":  # the integer sums and the shift's line sums without numba
        monkeypatch.setattr(int_fold, "fold", lambda *a, **k: None)
        monkeypatch.setattr(masked_fold, "_shift_c", None)
        monkeypatch.setattr(masked_fold, "_shift_loaded", True)
    rng = np.random.default_rng(13)
    shape = (23, 31)
    mask = rng.random(shape) < 0.06
    mask[4] = True  # a whole bad row
    info = np.iinfo(dtype)
    frames = rng.integers(max(info.min, -3000), min(info.max, 60000), size=(11,) + shape).astype(dtype)

    def fed(n, ride, readonly=False):
        full = StackAccumulator(shape, batch=3)
        acc = MaskedStackAccumulator(shape, mask, pixels=full)
        assert acc.ride() == ride if ride else True
        for f in frames[:n]:
            if readonly:  # a read-only view of bytes: the full stack keeps it, uncopied
                f = np.frombuffer(f.tobytes(), dtype).reshape(shape)
            full.add(f)
            if not ride:
                acc.add(f)
        return full, acc

    def state(acc):
        return (acc._r2, acc._c2, np.array(acc._t2), np.concatenate(acc._tot), *acc._sums(), acc.mean_map())

    for n in (11, 7):  # 7: two frames still in the full stack's batch when read
        _, want = fed(n, False)
        for readonly in (False, True):
            full, got = fed(n, True, readonly)
            assert got.n_frames == n and got._derived
            for a, b in zip(state(got), state(want)):
                np.testing.assert_array_equal(a, b)
            assert got.decompose_dark()["Pt"].value == want.decompose_dark()["Pt"].value
    full, got = fed(7, True)
    _, want = fed(7, False)
    more = frames[7:].astype(np.int32)  # another kind of frame: fed directly from here on
    got.unride()
    for f in more:
        full.add(f)
        got.add(f)
        want._pixels.add(f)
        want.add(f)
    assert not got.riding and got.n_frames == want.n_frames == 11
    np.testing.assert_array_equal(got.mean_map(), want.mean_map())
    np.testing.assert_array_equal(got._r2, want._r2)
