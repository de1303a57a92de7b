"""``levels.stack_moments`` sums integer frames as they are (squares in the narrowest type
that holds them), without int64 copies: the same numbers as the int64 sums it replaced."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.ptc.levels import stack_moments


def reference(frames):
    """The formulas of EMVA 1288 Eq. 33 on int64 copies (what stack_moments did before)."""
    x = np.stack(frames).astype(np.int64)
    n = len(frames)
    s1, s2 = x.sum(axis=0), (x * x).sum(axis=0)
    avg = s1 / n
    var_t = (s2 - s1 * avg) / (n - 1)
    return float(avg.mean()), float(np.var(avg, ddof=1)), float(np.mean(var_t)), avg


@pytest.mark.parametrize("dtype,lo,hi", [(np.uint8, 0, 256), (np.uint16, 0, 65536), (np.int8, -128, 128),
                                         (np.int16, -32768, 32768), (np.bool_, 0, 2), (np.int32, -2**20, 2**20)])
def test_integer_stacks_give_the_int64_sums(dtype, lo, hi):
    rng = np.random.default_rng(11)
    frames = [rng.integers(lo, hi, (23, 31)).astype(dtype) for _ in range(9)]
    frames[0][0, :4] = hi - 1 if dtype != np.bool_ else True  # the extremes, whose squares need the wider type
    frames[1][0, :4] = lo
    st, avg, _, _ = stack_moments(iter(frames))
    mean, s2m, s2t, ref_avg = reference(frames)
    assert (st.mean, st.s2_measured, st.s2_temporal) == pytest.approx((mean, s2m, s2t), rel=1e-15, abs=1e-12)
    assert np.array_equal(avg, ref_avg)


@pytest.mark.parametrize("hi,L", [(65536, 5), (4096, 300)])
def test_uint32_partial_sums_fold_before_they_overflow(hi, L):
    """Unsigned 8/16-bit frames are summed in uint32 and folded into the int64 totals before
    a sum of values or squares could pass 2**32: full-scale 16-bit frames (every frame folds)
    and stacks long enough to fold mid-way give the exact int64 sums."""
    rng = np.random.default_rng(5)
    dtype = np.uint8 if hi == 256 else np.uint16
    frames = [np.full((6, 7), hi - 1, dtype) if i % 3 == 0 else rng.integers(0, hi, (6, 7)).astype(dtype)
              for i in range(L)]
    st, avg, _, _ = stack_moments(iter(frames))
    mean, s2m, s2t, ref_avg = reference(frames)
    assert np.array_equal(avg, ref_avg)
    assert (st.mean, st.s2_measured, st.s2_temporal) == pytest.approx((mean, s2m, s2t), rel=1e-15, abs=1e-12)


def test_wrap_counts_fold_into_int64_after_65535_frames():
    """Full-scale 16-bit frames wrap the uint32 sum of squares every frame; the uint16 wrap
    count is emptied into an int64 total every 65535 frames: 70000 frames give Python's
    exact sums."""
    L = 70000
    frames = [np.array([[65535, 1, 40000]], np.uint16)] * (L - 2) + [np.array([[0, 7, 3]], np.uint16)] * 2
    st, avg, _, total = stack_moments(iter(frames))
    s1 = [sum(int(f[0, j]) for f in frames) for j in range(3)]
    s2 = [sum(int(f[0, j]) ** 2 for f in frames) for j in range(3)]
    assert total.ravel().tolist() == s1
    ref_t = np.mean([(s2[j] - s1[j] * (s1[j] / L)) / (L - 1) for j in range(3)])
    assert st.s2_temporal == pytest.approx(ref_t, rel=1e-9)
