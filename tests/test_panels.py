"""Result panels: robust Gaussian fit, ranges, histograms, per-pixel gain map."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.accumulate import StackAccumulator
from ares.analysis.panels import pixel_gain_map, result_panels, robust_gauss_fit, summarize, value_range
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
