"""The one-pass pair kernel (``ares.analysis.kernels.pair``) gives exactly the numbers of the
numpy path it replaces in ``levels.pair_moments``."""

from __future__ import annotations

import numpy as np
import pytest

import ares.analysis.kernels.pair as pk
from ares.analysis.ptc.levels import pair_moments


def _numpy_path(monkeypatch, a, b, max_code):
    with monkeypatch.context() as m:
        m.setattr(pk, "_kernel_c", None)
        m.setattr(pk, "_loaded", True)
        return pair_moments(a, b, max_code)


@pytest.mark.parametrize("dtype,max_code", [(np.uint16, 4095), (np.uint16, None), (np.uint8, 255), (np.int16, 1000)])
def test_pair_kernel_is_bit_identical_to_numpy(monkeypatch, dtype, max_code):
    rng = np.random.default_rng(3)
    hi = 256 if dtype == np.uint8 else 4096
    a = rng.integers(0, hi, (37, 53)).astype(dtype)
    b = rng.integers(0, hi, (37, 53)).astype(dtype)
    a[0, :5] = 0  # clipped black and white in both
    b[1, :3] = hi - 1
    fast = pair_moments(a, b, max_code)
    if pk._kernel_c is None:
        pytest.skip("numba not available: only the numpy path exists")
    ref = _numpy_path(monkeypatch, a, b, max_code)
    for k in ("sa", "sb", "sdd", "n", "fmax", "fmin"):
        assert getattr(fast, k) == getattr(ref, k), k
    for k in ("total", "row_diff", "col_diff"):
        assert np.array_equal(getattr(fast, k), getattr(ref, k)), k
    assert fast.total.dtype == ref.total.dtype == np.int32
    assert fast.stats(True) == ref.stats(True) and fast.stats(False) == ref.stats(False)
    assert fast.fmin > 0 and (max_code is None or fast.fmax > 0)


def test_float_and_mixed_pairs_take_the_numpy_path():
    a = np.ones((4, 5), np.float32)
    assert pk.pair_pass(a, a, None) is None
    assert pk.pair_pass(np.ones((4, 5), np.uint16), np.ones((4, 5), np.uint8), None) is None
    pm = pair_moments(a, a * 3)
    assert pm.sa == 20 and pm.sb == 60 and np.all(pm.row_diff == -2)


@pytest.mark.parametrize("dtype,shape,hi", [(np.uint16, (1536, 1536), 65536), (np.uint32, (40, 50), 2**24),
                                            (np.int32, (40, 50), 2**24)])
def test_numpy_path_sums_of_squares_are_exact_where_float64_would_round(monkeypatch, dtype, shape, hi):
    """The numpy path takes a - b in float64 and sums its squares there only while every
    partial sum is an integer below 2**53 (16-bit data up to ~2 Mpixel); beyond that (a
    2.4 Mpixel 16-bit pair at full range, 24-bit codes in 32-bit images) it sums in int64:
    the same exact integers as Python's."""
    rng = np.random.default_rng(5)
    a = rng.integers(0, hi, shape).astype(dtype)
    b = rng.integers(0, hi, shape).astype(dtype)
    a.flat[:7] = hi - 1  # the largest differences
    b.flat[:7] = 0
    m = _numpy_path(monkeypatch, a, b, None)
    d = a.astype(object).ravel() - b.astype(object).ravel()
    assert m.sdd == sum(int(x) * int(x) for x in d[:100_000]) + int(np.sum(np.square(
        (a.ravel()[100_000:].astype(np.int64) - b.ravel()[100_000:].astype(np.int64)).astype(object))))
    assert m.sa == int(a.astype(np.int64).sum()) and m.sb == int(b.astype(np.int64).sum())
    assert np.array_equal(m.avg, (a.astype(np.float64) + b.astype(np.float64)) / 2)
