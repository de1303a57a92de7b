"""The masked (unbalanced, Henderson method I) ANOVA of ares.analysis.noise.masked.

* an empty mask reproduces the balanced decomposition exactly (dark and flat);
* merging partial stacks equals one pass; values at masked pixels never matter;
* Monte Carlo on the Gaussian random-effects model with a heavy, irregular mask (10 %
  scattered pixels plus a whole row and a whole column): every component's mean is
  within 3 SEM of the truth and the reported SE matches the spread of the estimates.
"""

import math

import numpy as np
import pytest

from ares.analysis import MaskedStackAccumulator, StackAccumulator, decompose_dark, decompose_flat
from ares.analysis.noise.anova import anova_table
from ares.analysis.noise.masked import MaskedTable, masked_components
from ares.errors import InputError

TRUTH = dict(Cs=4.0, Ct=2.25, Rs=1.0, Rt=1.0, Ps=4.0, Pt=9.0, frame_global=4.0)


def _cube(rng, F, R, C, level=1000.0, truth=TRUTH, parts=None):
    """A stack of the random-effects model; ``parts`` (a dict) receives its Rs, Cs, Ps maps."""
    sd = {k: math.sqrt(v) for k, v in truth.items()}
    rs, cs = rng.normal(0, sd["Rs"], (1, R, 1)), rng.normal(0, sd["Cs"], (1, 1, C))
    x = (level + rng.normal(0, sd["Pt"], (F, R, C)) + rs
         + cs + rng.normal(0, sd["Rt"], (F, R, 1))
         + rng.normal(0, sd["Ct"], (F, 1, C)) + rng.normal(0, sd["frame_global"], (F, 1, 1)))
    ps = rng.normal(0, sd["Ps"], (1, R, C))
    if parts is not None:
        parts.update(Rs=rs.ravel(), Cs=cs.ravel(), Ps=ps[0])
    return x + ps


def _macc(x, mask):
    a = MaskedStackAccumulator(x.shape[1:], mask)
    a.add_batch(x)
    return a


def _acc(x):
    a = StackAccumulator(x.shape[1:])
    a.add_batch(x)
    return a


def test_empty_mask_equals_balanced_anova():
    rng = np.random.default_rng(1)
    x = np.round(_cube(rng, 12, 30, 40)).astype(np.uint16)
    none = np.zeros((30, 40), bool)
    d0, d1 = decompose_dark(_acc(x)), decompose_dark(_macc(x, none))
    for k in d0:
        assert d1[k].value == pytest.approx(d0[k].value, rel=1e-9, abs=1e-12), k
        assert d1[k].se == pytest.approx(d0[k].se, rel=1e-9), k


@pytest.mark.parametrize("illumination", ["none", "surface", "highpass"])
def test_empty_mask_equals_balanced_flat(illumination):
    rng = np.random.default_rng(2)
    R, C = 48, 56
    dark = np.round(_cube(rng, 8, R, C)).astype(np.uint16)
    gain = 1 + 0.01 * rng.standard_normal((R, C))
    flat = np.round(_cube(rng, 8, R, C, level=1000.0) + 3000 * gain + rng.normal(0, 20, (8, R, C))).astype(np.uint16)
    none = np.zeros((R, C), bool)
    a = decompose_flat(_acc(flat), _acc(dark), illumination=illumination)
    b = decompose_flat(_macc(flat, none), _macc(dark, none), illumination=illumination)
    for k in a:
        assert b[k].value == pytest.approx(a[k].value, rel=1e-7), k
        assert b[k].se == pytest.approx(a[k].se, rel=1e-6), k


def test_merge_and_masked_values_do_not_matter():
    rng = np.random.default_rng(3)
    x = _cube(rng, 10, 20, 24)
    mask = rng.random((20, 24)) < 0.1
    ref = decompose_dark(_macc(x, mask))
    y = x.copy()
    y[:, mask] = 1e6 * rng.random((10, int(mask.sum())))
    a = _macc(y[:4], mask)
    a.merge(_macc(y[4:], mask))
    assert a.n_frames == 10
    got = decompose_dark(a)
    for k in ref:
        assert got[k].value == pytest.approx(ref[k].value, rel=1e-8, abs=1e-9), k
    assert isinstance(anova_table(a), MaskedTable)
    assert np.isnan(a.mean_map()[mask]).all()
    # convenience on recorded stacks gives the same numbers
    assert masked_components(y, mask)["Ps"].value == pytest.approx(ref["Ps"].value, rel=1e-8)


def test_mask_errors():
    with pytest.raises(InputError):
        MaskedStackAccumulator((4, 5), np.zeros((5, 4), bool))
    a = MaskedStackAccumulator((4, 5), np.zeros((4, 5), bool))
    with pytest.raises(InputError):
        a.mean_map()
    with pytest.raises(InputError):
        a.add(np.zeros((5, 4)))
    b = MaskedStackAccumulator((4, 5), np.eye(4, 5, dtype=bool))
    with pytest.raises(InputError):
        a.merge(b)


def test_monte_carlo_heavy_irregular_mask():
    rng = np.random.default_rng(4)
    F, R, C, n = 10, 24, 32, 300
    mask = rng.random((R, C)) < 0.10
    mask[3, :] = True
    mask[:, 7] = True
    est = {k: [] for k in TRUTH}
    se = {k: [] for k in TRUTH}
    real = {k: [] for k in ("Rs", "Cs", "Ps")}  # the draw's patterns over the rows, columns, pixels with good cells
    good = ~mask
    for _ in range(n):
        parts: dict = {}
        d = decompose_dark(_macc(_cube(rng, F, R, C, parts=parts), mask))
        real["Rs"].append(parts["Rs"][good.any(axis=1)].var(ddof=1))
        real["Cs"].append(parts["Cs"][good.any(axis=0)].var(ddof=1))
        real["Ps"].append(parts["Ps"][good].var(ddof=1))
        for k in TRUTH:
            est[k].append(d[k].value)
            se[k].append(d[k].se)
    for k, t in TRUTH.items():
        e = np.array(est[k])
        sem = e.std(ddof=1) / math.sqrt(n)
        assert abs(e.mean() - t) < 3 * sem, (k, e.mean(), t, sem)
        # a pattern's SE is its measurement error, this sensor's pattern held (anova.py): against the
        # draw's own pattern variance; a temporal one's against the parameter
        err = e - np.array(real[k]) if k in real else e
        ratio = math.sqrt(np.mean(np.square(se[k]))) / err.std(ddof=1)
        assert 0.8 < ratio < 1.25, (k, ratio)


@pytest.mark.parametrize("dtype", [np.uint16, np.uint8, np.float32])
def test_masked_sums_from_the_full_frame_stack_are_the_same_numbers(dtype):
    """A masked stack given the full-frame StackAccumulator of the same frames (as a
    StackSet does) keeps no per-pixel sums of its own for 8/16-bit frames and gives
    exactly the numbers of one that keeps them; float frames keep their own."""
    rng = np.random.default_rng(11)
    hi = 250 if dtype == np.uint8 else 4000
    x = np.clip(rng.normal(hi / 2, hi / 20, (9, 23, 31)), 0, hi).astype(dtype)
    mask = rng.random((23, 31)) < 0.05
    full = StackAccumulator((23, 31), batch=4)
    own, derived = MaskedStackAccumulator((23, 31), mask), MaskedStackAccumulator((23, 31), mask, pixels=full)
    for f in x:
        full.add(f)
        own.add(f)
        derived.add(f)
    assert (derived._s1 is None) == (dtype != np.float32)
    assert np.array_equal(derived.mean_map(), own.mean_map(), equal_nan=True)
    assert np.array_equal(derived.pixel_ss(), own.pixel_ss(), equal_nan=True)
    assert derived.temporal_forms() == own.temporal_forms() and derived.mean() == own.mean()
    a, b = decompose_dark(derived), decompose_dark(own)
    assert all(a[k].value == b[k].value and a[k].se == b[k].se for k in a)
    # a merge takes the sums over (the full stack of the merged part stays its own)
    full2 = StackAccumulator((23, 31), batch=4)
    more = MaskedStackAccumulator((23, 31), mask, pixels=full2)
    for f in x[:3]:
        full2.add(f)
        more.add(f)
    own.merge(_macc(x[:3], mask))
    derived.merge(more)
    assert derived.n_frames == 12 and derived._s1 is not None
    assert np.array_equal(derived.pixel_ss(), own.pixel_ss(), equal_nan=True)
    # a masked view fed frames its full stack did not get is refused, not silently wrong
    lone = MaskedStackAccumulator((23, 31), mask, pixels=StackAccumulator((23, 31)))
    lone.add(x[0])
    lone.add(x[1])
    if dtype != np.float32:
        with pytest.raises(InputError, match="full-frame stack has 0 frames"):
            lone.mean_map()
