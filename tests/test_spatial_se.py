"""The SEs of the spatial variances (DSNU1288/PRNU1288 and their parts, EMVA 1288 4.0 Linear
Section 8, Eqs. 35 - 44; Release 3.0's stack variance) are the measurement error of THIS
sensor's pattern: over noise seeds of one fixed pattern, z = (split of the noisy stack's
average - split of the pattern itself) / SE has RMS ~1. The population's sampling SE
(sqrt(2 / n) times the variance, what ARES reported before) gives RMS ~0.1 here."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ares.analysis.emva.release3 import _spatial_se
from ares.analysis.ptc.levels import spatial_stats, stack_moments
from ares.analysis.spatial.nonuniformity import dsnu, split
from ares.analysis.spatial.pattern_se import part_variance

M, N, L, SEEDS, SIGMA = 64, 96, 16, 40, 3.0  # residual temporal variance 9/16: 1/16 of the pixel pattern's
PARTS = ("total", "col", "row", "pix")


def _pattern() -> np.ndarray:
    rng = np.random.default_rng(7)
    return 100 + rng.normal(0, 1.0, (M, 1)) + rng.normal(0, 2.0, (1, N)) + rng.normal(0, 3.0, (M, N))


def _z(row_sigma: float = 0.0) -> tuple[dict, dict, dict]:
    """z of the text's split and of option rowcol_corrected's, per part over SEEDS stacks of
    L frames: white noise SIGMA plus row-correlated temporal noise ``row_sigma``; and the
    old (population) SE's z of the text's split."""
    pat = _pattern()
    truth = split(pat, 0.0, 1, "4.0")
    text, ext, old = ({p: [] for p in PARTS} for _ in range(3))
    for s in range(SEEDS):
        r = np.random.default_rng(100 + s)
        frames = pat + r.normal(0, SIGMA, (L, M, N)) + r.normal(0, row_sigma, (L, M, 1))
        st, avg, line, _ = stack_moments(list(frames))
        sp = split(avg, line.pixel, L, "4.0", line.rows, line.cols, temporal_var_text=st.s2_temporal)
        for p in PARTS:
            v, se = sp.get(p)  # the figure's SE: the measurement's with the measured bias (std_estimate)
            text[p].append((v - truth.get(p)[0]) / math.hypot(se, sp.bias_of(p)))
            ve, see = sp.extended.get(p)
            ext[p].append((ve - truth.extended.get(p)[0]) / see)
            n = {"total": truth.rows * truth.cols, "pix": truth.rows * truth.cols, "col": truth.cols,
                 "row": truth.rows}[p]
            old[p].append((v - truth.get(p)[0]) / (math.sqrt(2 / n) * abs(truth.get(p)[0])))
    return ({p: np.asarray(v) for p, v in d.items()} for d in (text, ext, old))


def _rms(z: np.ndarray) -> float:
    return float(np.sqrt(np.mean(z * z)))


def test_split_se_is_the_measurement_error_of_this_pattern():
    text, ext, old = _z()
    for p in PARTS:
        assert 0.7 < _rms(text[p]) < 1.35, (p, _rms(text[p]))
        assert 0.7 < _rms(ext[p]) < 1.35, (p, _rms(ext[p]))
        assert np.max(np.abs(text[p])) < 4.0, p
        assert _rms(old[p]) < 0.5, (p, _rms(old[p]))  # the population's spread: 2 - 10x too wide here


def test_row_temporal_noise_the_text_takes_for_a_pattern_is_in_its_se():
    """Row-correlated temporal noise (sigma 2, measured by the line model): Eqs. 39 - 41 as
    written take its 4 / L for a row pattern (and Eq. 57's sigma^2 holds it, so the pixel
    part is over-subtracted): values as written, that bias (``Split.bias``) in the figures'
    SE (``std_estimate``) -- never many SE off; option rowcol_corrected removes it and keeps
    the measurement error alone."""
    text, ext, _ = _z(row_sigma=2.0)
    for p in PARTS:
        assert np.max(np.abs(text[p])) < 4.0, (p, np.max(np.abs(text[p])))
        assert 0.7 < _rms(ext[p]) < 1.35, (p, _rms(ext[p]))
    assert np.mean(text["row"]) > 0.5  # the bias is there, and held by the SE
    # ... as the figure shows it: DSNU1288.row keeps the text's value, its SE the bias, said so
    r = np.random.default_rng(1)
    frames = _pattern() + r.normal(0, SIGMA, (L, M, N)) + r.normal(0, 2.0, (L, M, 1))
    st, avg, line, _ = stack_moments(list(frames))
    sp = split(avg, line.pixel, L, "4.0", line.rows, line.cols, temporal_var_text=st.s2_temporal)
    e = dsnu(sp, 1.0, 0.0)["DSNU1288_row"]
    assert e.value == pytest.approx(math.sqrt(sp.row)) and "SE holds" in e.note
    assert e.se == pytest.approx(math.hypot(sp.se_row, sp.bias_of("row")) / (2 * math.sqrt(sp.row)))


def test_release3_stack_variance_se():
    rng = np.random.default_rng(8)
    pat = 100 + rng.normal(0, 3.0, (M, N))
    truth = float(np.var(pat, ddof=1))
    z = []
    for s in range(SEEDS):
        sp = spatial_stats(pat + np.random.default_rng(200 + s).normal(0, SIGMA, (L, M, N)))
        z.append((sp.s2_spatial - truth) / _spatial_se(sp))
    assert 0.7 < _rms(np.asarray(z)) < 1.35
    assert _spatial_se(sp) < 0.5 * math.sqrt(2 / (M * N)) * truth  # not the population's spread


def test_part_variance_is_the_noncentral_chi_square_variance():
    """(t/n) chi'^2(dof, n v_p / t) drawn by numpy has the variance ``part_variance`` gives
    (within 3 % on 40 000 draws); a pattern with no temporal noise claimed is known exactly
    (SE 0)."""
    rng = np.random.default_rng(9)
    for v_p, t, n, dof in ((9.0, 0.5, 3588, 3477), (1.0, 0.01, 46, 45), (1e-9, 2.0, 500, 499)):
        v = t / n * rng.noncentral_chisquare(dof, n * v_p / t, 40_000)
        assert part_variance(v_p + t * dof / n, t, n, dof) == pytest.approx(float(np.var(v)), rel=0.03)
    assert split(_pattern(), 0.0, L, "4.0").se_total == 0.0


def test_a_limit_holds_what_the_text_over_subtracted():
    """A variance driven below 0 by the text's over-subtraction (Eq. 57's frame offsets in
    sigma^2: bias < 0) is an upper limit on the pattern's s2 - bias, not on s2: the bound
    sqrt(max(s2 - bias, 0) + 2 SE) (the reference CCD's DSNU1288: -0.00213 +- 0.00058 DN^2,
    bias -0.0027). A positive bias (noise taken for a pattern) leaves the bound on s2."""
    from ares.analysis.spatial.nonuniformity import std_estimate

    e = std_estimate(-0.002, 0.0006, 1.0, 0.0, "DN", "", -0.003)
    assert e.bound == "upper" and e.value == pytest.approx(math.sqrt(0.001 + 0.0012))
    assert std_estimate(-0.002, 0.0006, 1.0, 0.0, "DN", "", 0.003).value == pytest.approx(math.sqrt(0.0012))
