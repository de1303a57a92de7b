"""Photon shot noise: exact Poisson at low charge (seed 001 shows q = 1 and 6 e-)."""

import numpy as np
import pytest
from scipy import stats

from ares.sim import SensorParams, SimSensor
from ares.sim import noise

# G = 1 DN/e-, qe = 1, nothing but shot noise: DN - black = photo-electrons exactly.
P = SensorParams(rows=48, cols=64, conversion_gain_uv_per_e=250.0, qe=1.0).noiseless()


def electrons(q, n=8, mode="exact", seed=0):
    f = SimSensor(P, seed).render(n, exposure_s=1.0, photon_flux=q, black_level_dn=64, shot_noise=mode)
    return f.astype(np.int64).ravel() - 64


@pytest.mark.parametrize("q", [1.0, 6.0, 1000.0])
@pytest.mark.parametrize("mode", ["exact", "auto"])
def test_poisson_mean_equals_variance(q, mode):
    e = electrons(q, mode=mode)
    n = e.size
    assert abs(e.mean() - q) < 4 * np.sqrt(q / n)
    # var of the sample variance of a Poisson: (mu4 - sigma^4)/n = (q + 2 q^2)/n
    assert abs(e.var(ddof=1) - q) < 4 * np.sqrt((q + 2 * q * q) / n)


@pytest.mark.parametrize("q", [1.0, 6.0])
def test_pmf_matches_scipy_poisson(q):
    e = electrons(q, n=8)
    assert e.min() >= 0
    kmax = int(q + 6 * np.sqrt(q) + 3)
    counts = np.bincount(np.minimum(e, kmax), minlength=kmax + 1)
    pmf = stats.poisson.pmf(np.arange(kmax + 1), q)
    pmf[-1] = stats.poisson.sf(kmax - 1, q)
    exp = pmf * e.size
    keep = exp > 5
    chi2 = np.sum((counts[keep] - exp[keep]) ** 2 / exp[keep])
    assert chi2 < stats.chi2.ppf(0.9999, keep.sum() - 1)
    if q == 1.0:  # the seed's first PDF: P(0) = P(1) = e^-1
        assert counts[0] / e.size == pytest.approx(np.exp(-1), abs=4 * np.sqrt(0.23 / e.size))
        assert counts[1] / e.size == pytest.approx(np.exp(-1), abs=4 * np.sqrt(0.23 / e.size))


def test_auto_mode_chooses_exact_where_skew_is_visible():
    assert noise.exact_mask(1.0, 1 / 12, "auto") is True
    assert noise.exact_mask(1e4, 1 / 12, "auto") is False
    # a few e- of read noise hides the skewness of a very small mean
    assert noise.exact_mask(0.01, 9.0, "auto") is False
    m = noise.exact_mask(np.array([1.0, 1e5]), 1 / 12, "auto")
    assert m.tolist() == [True, False]


def test_gaussian_mode_has_right_mean_and_variance_but_no_skew():
    q = 6.0
    e = SimSensor(P, 1).render(16, exposure_s=1.0, photon_flux=q, black_level_dn=64, shot_noise="gaussian")
    e = e.astype(np.float64).ravel() - 64
    assert abs(e.mean() - q) < 4 * np.sqrt(q / e.size)
    assert abs(e.var() - q - 1 / 12) < 4 * np.sqrt(2 / e.size) * q
    assert abs(stats.skew(e)) < 0.1  # Poisson skew would be 0.41


def test_fast_normal_table_has_unit_variance():
    rng = np.random.default_rng(0)
    z = noise.normal(rng, (200_000,), fast=True)
    assert z.dtype == np.float32
    assert abs(z.mean()) < 4 / np.sqrt(z.size)
    assert abs(z.var() - 1) < 4 * np.sqrt(2 / z.size)


@pytest.mark.parametrize("lam", [0.05, 1.5, 30.0])
def test_poisson_map_sampler_pmf(lam):
    rng = np.random.Generator(np.random.SFC64(5))
    m = np.full(100_000, lam)
    m[:10] = 50.0  # a few large means take the other branch
    x = noise.poisson_map(rng, m, m.shape)[10:].astype(np.int64)
    counts = np.bincount(x)
    exp = stats.poisson.pmf(np.arange(counts.size), lam) * x.size
    keep = exp > 5
    chi2 = np.sum((counts[keep] - exp[keep]) ** 2 / exp[keep])
    assert chi2 < stats.chi2.ppf(0.9999, max(keep.sum() - 1, 1))
    assert abs(x.mean() - lam) < 4 * np.sqrt(lam / x.size)
