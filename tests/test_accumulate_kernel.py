"""Exactness of the float32 + modular 8/16-bit kernel of StackAccumulator.

The kernel forms linear sums in float32 (exact below 2**24) and rebuilds each group's
16-bit sum of squares from a float32 estimate and the same sum modulo 2**16 (uint16
arithmetic). These tests hit the worst cases of that argument: full-scale codes (largest
squares and float32 rounding), 256-frame boundaries of the float32 totals, widths with
and without a column-run divisor, signed data, mixed dtypes, merges and 10,000 frames.
Every comparison is against exact integer arithmetic (int64 / Python int), for both
kernels: the fused numba one (``ares.analysis.kernels.int_fold``) and the numpy one it replaces
where numba is available.
"""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.kernels import int_fold
from ares.analysis.noise.accumulate import StackAccumulator


@pytest.fixture(autouse=True, params=["numba", "numpy"])
def kernel(request, monkeypatch):
    """Every test here runs on the fused numba kernel and on the numpy kernel."""
    if request.param == "numba":
        int_fold.warm()
        if int_fold._kernel_c is None:
            pytest.skip("numba is not available here (ARES_NO_NUMBA or not installed)")
    else:
        monkeypatch.setattr(int_fold, "fold", lambda *a, **k: None)
    return request.param


def _exact(frames):
    """Exact reference sums (int64 is enough for these sizes; asserted)."""
    x = np.asarray(frames).astype(np.int64)
    s2 = np.einsum("fij,fij->ij", x, x)
    assert int(np.abs(x).max()) ** 2 * len(x) < 2**62
    return x.sum(0), s2, x.sum(2), x.sum(1)


def _check(a, frames):
    s1, s2, fr, fc = _exact(frames)
    a._flush()
    assert np.array_equal(a._s1, s1)
    assert np.array_equal(a._s2, s2)
    if a.keep_profiles:
        assert np.array_equal(np.concatenate(a._fr), fr)
        assert np.array_equal(np.concatenate(a._fc), fc)
    assert np.array_equal(np.concatenate(a._tot), fr.sum(1))
    n = len(frames)
    if n > 1:  # exact-rational variance: same float as the exact integers give
        num = n * s2 - s1 * s1
        assert np.array_equal(a.temporal_var_map(), num / (n * (n - 1)))


def _feed(shape, frames, mode="add", **kw):
    a = StackAccumulator(shape, keep_profiles=True, **kw)
    if mode == "add":
        for f in frames:
            a.add(f)
    elif mode == "nocopy":
        for f in frames:
            a.add(f, copy=False)
    else:
        a.add_batch(np.asarray(frames))
    return a


# widths: divisible into column runs (240 | 480), a prime (explicit segments), tiny
SHAPES = [(5, 480), (3, 1021), (4, 7)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("mode", ["add", "nocopy", "batch"])
def test_16bit_full_scale_across_float32_flushes(shape, mode):
    # 600 frames: crosses the 256-frame moves of the float32 totals twice
    nf = 600
    x = np.full((nf,) + shape, 65535, np.uint16)
    x[::7] = 0
    x[3::11] = 65534
    _check(_feed(shape, x, mode), x)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("batch", [1, 7, 8, 9, 16, 64])
def test_16bit_random_full_range_any_batch(shape, batch):
    rng = np.random.default_rng(batch)
    x = rng.integers(0, 65536, (75,) + shape).astype(np.uint16)
    _check(_feed(shape, x, batch=batch), x)


def test_16bit_worst_float32_rounding_codes():
    # codes whose squares round worst in float32 (odd, near 2**16 and 2**15.5)
    codes = np.array([65535, 65533, 65531, 46341, 46339, 32769, 65279, 65281], np.uint16)
    rng = np.random.default_rng(3)
    x = rng.choice(codes, size=(300, 6, 250)).astype(np.uint16)
    _check(_feed((6, 250), x), x)


def test_12bit_max_code_300_frames():
    x = np.full((300, 8, 512), 4095, np.uint16)
    _check(_feed((8, 512), x), x)
    _check(_feed((8, 512), x, mode="batch"), x)


@pytest.mark.parametrize("dtype", [np.int16, np.uint8, np.int8])
def test_other_small_int_types_extremes(dtype):
    info = np.iinfo(dtype)
    rng = np.random.default_rng(5)
    x = rng.choice(np.array([info.min, info.max, info.min + 1, info.max - 1, 0], dtype), size=(520, 4, 300))
    for mode in ("add", "nocopy", "batch"):
        _check(_feed((4, 300), x, mode), x)


def test_mixed_dtypes_exact():
    rng = np.random.default_rng(11)
    frames = []
    a = StackAccumulator((5, 260), keep_profiles=True)
    for i in range(300):
        dt = (np.uint8, np.uint16, np.int16)[(i // 5) % 3]
        info = np.iinfo(dt)
        f = rng.integers(info.min, int(info.max) + 1, (5, 260)).astype(dt)
        frames.append(f.astype(np.int64))
        a.add(f)
    _check(a, np.array(frames))


def test_merge_full_scale_exact():
    x = np.full((530, 3, 480), 65535, np.uint16)
    x[1::3] = 12345
    p1 = _feed((3, 480), x[:277])
    p2 = _feed((3, 480), x[277:], mode="batch")
    p1.merge(p2)
    one = _feed((3, 480), x)
    _check(p1, x)
    one._flush()
    assert p1._qfr == one._qfr and p1._qfc == one._qfc
    assert p1.temporal_sums() == one.temporal_sums()


@pytest.mark.slow
def test_10000_frames_16bit_full_scale():
    nf = 10_000
    rng = np.random.default_rng(2)
    pool = rng.integers(60000, 65536, (16, 2, 480)).astype(np.uint16)
    pool[0] = 65535
    a = StackAccumulator((2, 480))
    for i in range(nf):
        a.add(pool[i % 16])
    x = pool[np.arange(nf) % 16]
    s1, s2, _, _ = _exact(x)
    a._flush()
    assert np.array_equal(a._s1, s1)
    assert np.array_equal(a._s2, s2)
    num = nf * s2.astype(object) - s1.astype(object) ** 2  # Python ints: beyond int64
    ref = np.array([float(v) for v in num.ravel()]).reshape(num.shape) / (nf * (nf - 1))
    np.testing.assert_allclose(a.temporal_var_map(), ref, rtol=1e-15)


def test_centred_and_uncentred_paths_interleaved():
    # copied uint16 frames are stored centred (x ^ 0x8000), referenced read-only frames
    # are centred while gathered, add_batch arrays are folded uncentred: any interleaving
    # (and int16 / uint8 in between) must give the exact sums
    rng = np.random.default_rng(9)
    shape = (6, 300)
    a = StackAccumulator(shape, batch=5, keep_profiles=True)
    frames = []
    for step in range(60):
        kind = step % 6
        if kind == 0:
            f = rng.integers(0, 65536, shape).astype(np.uint16)
            a.add(f)
            frames.append(f)
        elif kind == 1:  # immutable: referenced, not copied
            f = rng.integers(60000, 65536, shape).astype(np.uint16)
            a.add(np.frombuffer(f.tobytes(), np.uint16).reshape(shape))
            frames.append(f)
        elif kind == 2:
            blk = rng.integers(0, 65536, (3,) + shape).astype(np.uint16)
            a.add_batch(blk)
            frames.extend(blk)
        elif kind == 3:
            f = rng.integers(-32768, 32768, shape).astype(np.int16)
            a.add(f)
            frames.append(f)
        elif kind == 4:
            f = np.full(shape, 65535, np.uint16)
            a.add(f, copy=False)
            frames.append(f)
        else:
            f = rng.integers(0, 256, shape).astype(np.uint8)
            a.add(f)
            frames.append(f)
    _check(a, np.array([np.asarray(f, np.int64) for f in frames]))


@pytest.mark.parametrize("dtype", [np.uint16, np.int16, np.uint8])
def test_tall_frames_column_sums_over_many_row_runs(dtype):
    # > 256 rows: the float32 column sums are moved to float64 every <= 256 rows
    info = np.iinfo(dtype)
    x = np.full((40, 700, 40), info.max, dtype)
    x[::2, ::3] = info.min
    for mode in ("add", "batch"):
        _check(_feed((700, 40), x, mode), x)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16])
def test_clip_counts_equal_numpy(dtype):
    """The one-pass count of clipped values (at or above the top code, and 0) on whole
    frames and strided Bayer planes, the top code inside and beyond the type's range."""
    rng = np.random.default_rng(2)
    info = np.iinfo(dtype)
    d = rng.integers(max(info.min, -5), min(info.max, 4100), (37, 50)).astype(dtype)
    d[0, :7] = 0
    for top in (4095, 200, 70000):
        for view in (d, d[::2, 1::2]):
            want = (int(np.count_nonzero(view >= top)), int(np.count_nonzero(view == 0)))
            assert int_fold.extremes(view, top) == want


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16])
def test_clip_counts_in_the_fold_equal_numpy(dtype):
    """The accumulator's clip counts (counted in the fused kernel's pass, or per block on
    the numpy path) equal numpy's counts of the frames as added: through the batch store
    (uint16 held as x ^ 0x8000), frames that are not copied (read-only), ``add_batch``,
    strided Bayer planes, a partly filled batch, a merge, and a top beyond the type."""
    rng = np.random.default_rng(5)
    info = np.iinfo(dtype)
    x = rng.integers(max(info.min, -3), min(info.max, 4100) + 1, (7, 30, 40)).astype(dtype)
    x[:, 0, :9] = 0
    x[2, 1, :5] = min(info.max, 4100)
    for top in (4095, 100, 70000):
        for view in ((slice(None), slice(None)), (slice(1, None, 2), slice(0, None, 2))):
            frames = x[:, view[0], view[1]]
            want = (int(np.count_nonzero(frames.astype(np.int64) >= top)), int(np.count_nonzero(frames == 0)))
            shape = frames.shape[1:]
            for mode in ("add", "readonly", "batch", "merge"):
                a = StackAccumulator(shape, batch=3)
                a.count_clips(top)
                if mode == "add":
                    for f in frames:
                        a.add(f)
                elif mode == "readonly":
                    for f in frames:  # a read-only view of bytes: kept, not copied
                        a.add(np.frombuffer(np.ascontiguousarray(f).tobytes(), dtype).reshape(shape))
                elif mode == "batch":
                    a.add_batch(np.ascontiguousarray(frames))
                else:
                    b = StackAccumulator(shape, batch=3)
                    b.count_clips(top)
                    for f in frames[:4]:
                        a.add(f)
                    for f in frames[4:]:
                        b.add(f)
                    a.merge(b)
                assert a.clips() == want, (mode, top)
                _check(a, np.asarray(frames, np.int64))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16])
def test_fold_split_over_threads_equals_exact_sums(dtype, kernel, monkeypatch):
    """The fused kernel split into bands of rows folded on several threads (as a 4096x3072
    block is): the sums, row and column sums and clip counts equal exact integer arithmetic,
    for any number of bands (one band a row, more bands than rows), and the accumulator's
    default split (forced on for these small frames) gives the same sums."""
    if kernel != "numba":
        pytest.skip("the split is the numba kernel's")
    rng = np.random.default_rng(11)
    info = np.iinfo(dtype)
    x = rng.integers(info.min, int(info.max) + 1, (3, 13, 29)).astype(dtype)
    x[1, 4, :6] = 0
    off = 1 << 15 if dtype == np.int16 else 0
    y = x.astype(np.int64) + off
    top = int(np.percentile(y, 90))
    for parts in (1, 2, 3, 13, 40):
        s1, s2, cnt = np.full((13, 29), 7, np.int64), np.zeros((13, 29), np.int64), np.array([5, 1], np.int64)
        fr, fc = int_fold.fold(x, off, s1, s2, top, cnt, parts=parts)
        assert np.array_equal(s1, y.sum(0) + 7) and np.array_equal(s2, (y * y).sum(0)), parts
        assert np.array_equal(fr, y.sum(2)) and np.array_equal(fc, y.sum(1)), parts
        assert cnt.tolist() == [5 + int((y >= top).sum()), 1 + int((y == 0).sum())], parts
    monkeypatch.setattr(int_fold, "SPLIT_VALUES", 1)
    monkeypatch.setenv("ARES_FOLD_THREADS", "3")
    frames = rng.integers(info.min, int(info.max) + 1, (20, 13, 29)).astype(dtype)
    for mode in ("add", "batch"):
        _check(_feed((13, 29), frames, mode), frames)
