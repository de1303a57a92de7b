"""Chi-square and F upper tails (``ares.analysis.stats.tails``) against scipy.special."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import special

from ares.analysis.stats.tails import chi2_sf, f_sf


@pytest.mark.parametrize("df", [1, 2, 3, 5, 10, 22, 47, 100, 500, 2000])
def test_chi2_upper_tail_equals_scipy(df):
    for x in [1e-8, 1e-3, 0.5, 1, df - 1, df, df + 1, 2 * df, 5 * df, 20 * df + 50, 3e4]:
        ref = float(special.chdtrc(df, x))
        if ref > 1e-290:
            assert chi2_sf(df, x) == pytest.approx(ref, rel=1e-10, abs=0), (df, x)
    assert chi2_sf(df, 0.0) == 1.0 and chi2_sf(df, math.inf) == 0.0


@pytest.mark.parametrize("d1", [1, 2, 5])
@pytest.mark.parametrize("d2", [1, 3, 10, 45, 2000])
def test_f_upper_tail_equals_scipy(d1, d2):
    for x in [1e-6, 1e-3, 0.1, 1, 3, 10, 100, 1e4, 1e8]:
        ref = float(special.fdtrc(d1, d2, x))
        if ref > 1e-290:
            assert f_sf(d1, d2, x) == pytest.approx(ref, rel=1e-10, abs=0), (d1, d2, x)
    assert f_sf(d1, d2, 0.0) == 1.0 and f_sf(d1, d2, math.inf) == 0.0


def test_bad_arguments_give_nan():
    assert math.isnan(chi2_sf(0, 1.0)) and math.isnan(chi2_sf(3, math.nan))
    assert math.isnan(f_sf(0, 3, 1.0)) and math.isnan(f_sf(1, 3, math.nan))


def test_tail_of_a_simulated_chi_square_sample():
    """The p-value is uniform under the null: the fraction below 0.05 of 20000 draws."""
    rng = np.random.default_rng(4)
    p = np.array([chi2_sf(7, x) for x in rng.chisquare(7, 20000)])
    assert abs(np.mean(p < 0.05) - 0.05) < 4 * math.sqrt(0.05 * 0.95 / 20000)
