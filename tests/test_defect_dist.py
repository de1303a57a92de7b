"""The defect classifier's chi-square/normal quantiles and trimmed mean equal scipy.stats'."""

import numpy as np
import pytest
from scipy import stats

from ares.analysis.defects.dist import chi2_isf, chi2_ppf, norm_cdf, trim_mean


@pytest.mark.parametrize("dof", [1, 2, 7, 99, 4095])
@pytest.mark.parametrize("p", [1e-9, 1e-3, 0.01, 0.5, 0.99])
def test_chi2_quantiles(dof, p):
    assert chi2_ppf(p, dof) == pytest.approx(stats.chi2.ppf(p, dof), rel=1e-10)
    assert chi2_isf(p, dof) == pytest.approx(stats.chi2.isf(p, dof), rel=1e-10)


def test_norm_cdf():
    x = np.linspace(-9, 9, 101)
    np.testing.assert_allclose(norm_cdf(x), stats.norm.cdf(x), rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("shape", [(7, 5), (40, 33), (3, 1)])
def test_trim_mean(shape):
    a = np.random.default_rng(4).standard_normal(shape) ** 3
    for axis in (0, 1):
        np.testing.assert_allclose(trim_mean(a, 0.1, axis), stats.trim_mean(a, 0.1, axis=axis), rtol=1e-12)
        np.testing.assert_allclose(trim_mean(a, 0.25, axis), stats.trim_mean(a, 0.25, axis=axis), rtol=1e-12)
