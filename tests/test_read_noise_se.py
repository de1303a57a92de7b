"""The read noise's SE against its closed-form truth: dark stacks of white, row- and
column-correlated Gaussian temporal noise (and a frame-global offset, which the level removes),
read the way a photon-transfer run reads them -- the stack's level statistics, the dark
ANOVA's Rt and Ct (``results.analyses._read_noise_with_line_terms``), and one matched dark
reused by every level (each stage carries its own copy). The SE must describe the error:
z = (value - truth) / SE has SD ~1 over a few hundred draws."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ares.analysis.noise.accumulate import StackAccumulator
from ares.analysis.noise.anova import decompose_dark
from ares.analysis.ptc.levels import stack_stats
from ares.analysis.ptc.noise_figures import read_noise
from ares.analysis.stats.estimate import Estimate
from ares.results.analyses import _read_noise_with_line_terms

R, C, F = 24, 32, 4
PT, RT, CT, FG = 1.0, 0.3, 0.3, 0.3  # DN^2: white, row, column, frame-global temporal variances
K = Estimate(0.25, 0.0, "DN/e-")  # exact, so the e- figure's z is the variance's


def _draw(rng) -> tuple[Estimate, Estimate]:
    x = (rng.normal(0, math.sqrt(PT), (F, R, C)) + rng.normal(0, math.sqrt(RT), (F, R, 1))
         + rng.normal(0, math.sqrt(CT), (F, 1, C)) + rng.normal(0, math.sqrt(FG), (F, 1, 1)) + 100.0)
    acc = StackAccumulator((R, C))
    acc.add_batch(x)
    comp = {k: v.to_dict() for k, v in decompose_dark(acc).items()}
    lv = stack_stats(x)
    dark = [stack_stats(x) for _ in range(25)]  # 25 levels, each with its copy of the one dark
    dn, e, upper = read_noise(dark, None, K)
    assert not upper and lv == dark[0]
    r = SimpleNamespace(read_noise_dn=dn, read_noise_e=e, read_noise_is_upper_limit=upper, gain_dn_per_e=K)
    return _read_noise_with_line_terms(r, [{"views": {"full": {"components": comp}}}], "components", dark[0])


def test_the_read_noise_se_describes_its_error_over_many_dark_stacks():
    # truth: the mean per-pixel temporal variance with the frame means removed (EMVA 1288 4.0 Linear Eq. 18's
    # offset correction), as the scan-truth tests take it
    s2 = PT * (1 - 1 / (R * C)) + RT * (1 - 1 / R) + CT * (1 - 1 / C)
    rng = np.random.default_rng(61)
    z_dn, z_e = [], []
    for _ in range(200):
        dn, e = _draw(rng)
        z_dn.append((dn.value - math.sqrt(s2)) / dn.se)
        z_e.append((e.value - math.sqrt(s2 - 1 / 12) / K.value) / e.se)
    for z in (np.array(z_dn), np.array(z_e)):
        # without the Rt, Ct sampling the SE is ~1.6x too small here
        assert 0.85 < z.std(ddof=1) < 1.15 and abs(z.mean()) < 0.2, (z.mean(), z.std(ddof=1))
        assert np.mean(np.abs(z) > 3) < 0.015


def test_a_matched_dark_reused_by_every_level_is_counted_once():
    """Each stage carries its own copy of the one dark: 25 copies are one measurement, not 25
    (counted by identity, the weighted mean's SE was 5x too small)."""
    x = np.random.default_rng(3).normal(100.0, 1.0, (F, R, C))
    one, _, _ = read_noise([stack_stats(x)], None, K)
    many, _, _ = read_noise([stack_stats(x) for _ in range(25)], None, K)
    assert one.se > 0 and many.se == pytest.approx(one.se, rel=1e-9) and many.value == pytest.approx(one.value, rel=1e-12)
