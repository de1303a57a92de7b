"""The one-pass pair kernel (``ares.analysis.pair_kernel``) gives exactly the numbers of the
numpy path it replaces in ``levels.pair_moments``."""

from __future__ import annotations

import numpy as np
import pytest

import ares.analysis.pair_kernel as pk
from ares.analysis.levels import pair_moments


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
    for k in ("avg", "row_diff", "col_diff"):
        assert np.array_equal(getattr(fast, k), getattr(ref, k)), k
    assert fast.stats(True) == ref.stats(True) and fast.stats(False) == ref.stats(False)
    assert fast.fmin > 0 and (max_code is None or fast.fmax > 0)


def test_float_and_mixed_pairs_take_the_numpy_path():
    a = np.ones((4, 5), np.float32)
    assert pk.pair_pass(a, a, None) is None
    assert pk.pair_pass(np.ones((4, 5), np.uint16), np.ones((4, 5), np.uint8), None) is None
    pm = pair_moments(a, a * 3)
    assert pm.sa == 20 and pm.sb == 60 and np.all(pm.row_diff == -2)
