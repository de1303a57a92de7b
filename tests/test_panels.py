"""Result panels: robust Gaussian fit, ranges, histograms, per-pixel gain map."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.noise.accumulate import StackAccumulator
from ares.analysis.noise.panels import pixel_gain_map, result_panels, robust_gauss_fit, summarize, value_range
from ares.errors import InputError


def test_robust_fit_ignores_outlier_tail():
    rng = np.random.default_rng(0)
    v = rng.normal(100.0, 2.0, 20000)
    v[:400] = rng.uniform(150, 4000, 400)  # 2 % hot pixels
    mu, s = robust_gauss_fit(v)
    assert abs(mu - 100) < 0.1 and abs(s - 2) < 0.1
    assert v.std() > 50  # the plain sigma is ruined by the tail
    p = summarize("Mean Signal", v)
    assert p.highest > 3000 and p.lowest < 95
    lo, hi = value_range(v[400:], "percentile", (0.1, 99.9))
    assert 92 < lo < 95 and 105 < hi < 108
    with pytest.raises(InputError, match="range mode"):
        value_range(v, "bogus")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_robust_fit_equals_scipy_curve_fit_on_the_same_bins(seed):
    """The panels' Gaussian (lsq.levenberg_marquardt) against scipy's curve_fit with the
    same bins, weights and start: the same mean and sigma to MINPACK's tolerance."""
    from scipy.optimize import curve_fit

    rng = np.random.default_rng(seed)
    v = np.r_[rng.normal(50.0, 3.0, 5000), rng.uniform(80, 500, 50)]
    mu, s = robust_gauss_fit(v)
    med = float(np.median(v))
    mad = float(np.median(np.abs(v - med))) * 1.4826
    counts, edges = np.histogram(v[(v >= med - 4 * mad) & (v <= med + 4 * mad)], bins=128,
                                 range=(med - 4 * mad, med + 4 * mad))
    c = 0.5 * (edges[1:] + edges[:-1])
    k = counts > 0.05 * counts.max()
    ref, _ = curve_fit(lambda x, a, m, w: a * np.exp(-0.5 * ((x - m) / w) ** 2), c[k], counts[k],
                       p0=(counts.max(), med, mad), sigma=np.sqrt(counts[k] + 1.0))
    assert mu == pytest.approx(ref[1], rel=1e-7) and s == pytest.approx(abs(ref[2]), rel=1e-6)
    assert abs(mu - 50) < 0.2 and abs(s - 3) < 0.2


def test_constant_data_fit():
    mu, s = robust_gauss_fit(np.full(1000, 5.0))
    assert mu == 5.0 and s == 0.0


def test_result_panels_on_stack():
    rng = np.random.default_rng(1)
    x = (1000 + rng.normal(0, 3, (6, 32, 40)) + rng.normal(0, 5, (32, 40))).round().astype(np.uint16)
    acc = StackAccumulator((32, 40))
    acc.add_batch(x)
    panels = result_panels(acc, range_mode="percentile")
    assert set(panels) == {"Mean Signal", "Noise", "Columns", "Rows"}
    assert abs(panels["Mean Signal"].mean - x.mean()) < 1e-9
    assert abs(panels["Noise"].fitted_mean - 3) < 0.4
    assert panels["Columns"].data.shape == (40,)
    assert panels["Rows"].data.shape == (32,)
    assert panels["Noise"].counts.sum() > 0.99 * 32 * 40 * 0.998 - 5
    assert "fitted_sigma" in panels["Rows"].as_dict()


def test_pixel_gain_map():
    rng = np.random.default_rng(2)
    R, C, F, K = 8, 10, 40, 0.25
    gmap = K * (1 + 0.05 * rng.standard_normal((R, C)))
    levels = []
    dark = StackAccumulator((R, C))
    dark.add_batch(100 + rng.normal(0, 1.5, (F, R, C)))
    for q in (1000, 4000, 8000):
        flat = StackAccumulator((R, C))
        flat.add_batch(100 + gmap * (q + np.sqrt(q) * rng.standard_normal((F, R, C))) + rng.normal(0, 1.5, (F, R, C)))
        levels.append((flat, dark))
    est = pixel_gain_map(levels)
    assert np.median(np.abs(est / gmap - 1)) < 0.2
    with pytest.raises(InputError, match="levels"):
        pixel_gain_map(levels[:1])
