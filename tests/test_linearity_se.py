"""The linearity error's SE (issue 52: every number with its SE): the levels' signal SEs
propagated through the 1/S-weighted line to the extreme level, against a Monte Carlo of
the same levels redrawn with those SEs (closed-form truth: the spread of max |dev|)."""

from __future__ import annotations

import pytest
import numpy as np

from ares.analysis.ptc.fit import max_relative_deviation


def _draws(y_true, x, se, n, rng):
    out = np.empty(n)
    for i in range(n):
        out[i] = max_relative_deviation(x, y_true + rng.normal(0, se), se)[0]
    return out


def test_se_matches_the_spread_of_the_max_deviation():
    rng = np.random.default_rng(5)
    x = np.linspace(1, 10, 9)
    y_true = 400 * x * (1 - 0.03 * (x / 10) ** 6)  # a roll-off at the top: one extreme level in every draw
    se = 0.002 * y_true  # 0.2 % per level
    le, le_se, dev = max_relative_deviation(x, y_true, se)
    mc = _draws(y_true, x, se, 3000, rng)
    assert abs(le_se / mc.std(ddof=1) - 1) < 0.1, (le_se, mc.std(ddof=1))
    assert abs(mc.mean() - le) < 3 * le_se
    # the deviations are the relative residuals of the weighted line: a straight line has none
    lin = max_relative_deviation(x, 400 * x + 7, se)
    assert lin[0] < 1e-9 and lin[1] > 0


def test_ptc_result_carries_the_se(tmp_path):
    """analyze_ptc's linearity error is the same function's value, with a finite SE."""
    from ares.analysis.ptc.levels import LevelStats
    from ares.analysis.ptc.photon_transfer import analyze_ptc

    k, n_pix, n_fr = 0.25, 4096, 8
    t = np.linspace(0.001, 0.03, 16)
    q = 15000.0 / 0.03 * t  # e-; the ADC clips at 10 000 e- (above 0.02 s)
    dark = [LevelStats(100.0, 4.0, n_pix, n_fr) for _ in t]
    bright = []
    for e in q:
        s = k * min(e, 10000.0) * (1 - 0.01 * min(e, 10000.0) / 10000.0)  # a 1 % bow
        clip = 1.0 if e > 10000.0 else 0.0
        bright.append(LevelStats(100.0 + s, 4.0 + (k * s if not clip else 0.0), n_pix, n_fr, frac_at_max=clip))
    r = analyze_ptc(bright, dark, exposure_s=t)
    le = r.linearity_error_pct
    assert le.available and np.isfinite(le.se) and le.se > 0, le
    assert "SE: each level's signal SE (temporal noise / sqrt(N))" in le.note


def test_a_linearity_error_within_its_noise_is_the_one_limit_rule():
    """A linearity error smaller than its SE is an upper limit at value + 3 SE (``stats.physical.
    NSIGMA``, the one rule every other limit follows), and its note says + 3 SE."""
    import re

    from ares.analysis.ptc.levels import LevelStats
    from ares.analysis.ptc.photon_transfer import analyze_ptc
    from ares.analysis.stats.physical import NSIGMA

    k, n_pix, n_fr = 0.25, 64, 2  # few pixels and frames: the SE is large against a perfect line
    t = np.linspace(0.001, 0.03, 16)
    q = 15000.0 / 0.03 * t
    dark = [LevelStats(100.0, 4.0, n_pix, n_fr) for _ in t]
    bright = []
    for e in q:
        clip = 1.0 if e > 10000.0 else 0.0
        s = k * min(e, 10000.0)
        bright.append(LevelStats(100.0 + s, 4.0 + (k * s if not clip else 0.0), n_pix, n_fr, frac_at_max=clip))
    le = analyze_ptc(bright, dark, exposure_s=t).linearity_error_pct
    assert le.verdict == "upper limit", le
    v, se = (float(x) for x in re.match(r"([0-9.e+-]+) ± ([0-9.e+-]+) %", le.note).groups())
    assert f"value + {NSIGMA:g} SE" in le.note
    assert le.value == pytest.approx(v + NSIGMA * se, rel=0.05)
