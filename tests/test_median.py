"""The medians and quantiles ARES computes without numpy's (whose first use imports
numpy.ma: 12 ms of `ares emva`) give numpy's floats exactly."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.stats.median import fast_median, n_distinct, sorted_quantiles


@pytest.mark.parametrize("shape", [(1,), (2,), (7,), (8,), (5, 6), (6, 5), (3, 4, 5)])
@pytest.mark.parametrize("dtype", [np.float64, np.uint16, np.int32])
def test_fast_median_is_numpys_median(shape, dtype):
    rng = np.random.default_rng(sum(shape))
    a = (rng.normal(100, 30, shape) if dtype == np.float64 else rng.integers(0, 4096, shape)).astype(dtype)
    assert fast_median(a) == np.median(a)
    for axis in range(a.ndim):
        assert np.array_equal(fast_median(a, axis=axis), np.median(a, axis=axis))


@pytest.mark.parametrize("n", [1, 2, 5, 12, 13, 40])
def test_sorted_quantiles_are_numpys(n):
    rng = np.random.default_rng(n)
    s = np.sort(np.round(rng.lognormal(5, 2, n), 1))  # ties included
    q = np.r_[0.0, np.linspace(0, 1, 7)[1:-1], 1.0, 0.5, 1 / 3, 0.999999]
    assert np.array_equal(sorted_quantiles(s, q), np.quantile(s, q))


def test_n_distinct_is_numpys_unique_count():
    t = [0.01, 0.02, 0.01, 0.04, np.float32(0.02), 0.04, 1e-9]  # float32 0.02 is another float64
    assert n_distinct(t) == np.unique(np.asarray(t, float)).size == 5
    assert n_distinct(np.array([3.0])) == 1 and n_distinct([]) == 0
