"""Dark current vs exposure and temperature on local synthetic darks (known truth)."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.ptc.dark_current import dark_current, doubling_temperature, dsnu_vs_exposure
from ares.analysis.ptc.levels import pair_stats


def darks(rng, t, rate_map, K=0.3, read_e=3.0, offset=100.0, shape=(96, 96)):
    out = []
    for _ in range(2):
        q = rng.poisson(rate_map * t)
        out.append(np.round(K * (q + rng.normal(0, read_e, shape)) + offset).astype(np.uint16))
    return np.stack(out)


def test_dark_current_from_mean_and_variance():
    rng = np.random.default_rng(2)
    rate = np.full((96, 96), 40.0)
    t = np.array([0.01, 0.5, 1, 2, 3, 4, 5])
    st = [pair_stats(*darks(rng, x, rate)) for x in t]
    r = dark_current(t, [s.mean for s in st], 0.3, [s.var for s in st])
    assert abs(r.rate_e_per_s.value - 40) < 4 * r.rate_e_per_s.se + 0.2
    assert r.rate_from_variance_e_per_s.value == pytest.approx(40, rel=0.1)
    few = dark_current(t[:4], [s.mean for s in st[:4]], 0.3)
    assert not few.rate_e_per_s.available and ">= 6" in few.rate_e_per_s.note


def test_dsnu_vs_exposure():
    t = np.array([0.0, 0.5, 1, 2, 4, 8])
    A, D = 2.0, 1.5
    s = np.sqrt(A**2 + (t * D) ** 2)
    f = dsnu_vs_exposure(t, s, 0.5)
    assert f.a_dn.value == pytest.approx(A, rel=1e-6)
    assert f.dsnu_dn_per_s.value == pytest.approx(D, rel=1e-6)
    assert f.dsnu_e_per_s.value == pytest.approx(3.0, rel=1e-6)


def test_dsnu_not_resolved_from_0_is_an_upper_limit_and_3_se_cover_the_truth():
    """The spatial sigma barely growing with exposure, 2 % scatter (the temperature scan at 2
    frames gave DSNU 0.16 ± 0.67 DN/s "ok"): the fitted square is not resolved from 0, so the
    DSNU is only the upper limit sqrt(square + 3 SE) -- in DN/s and e-/s -- and that limit
    holds the truth; a resolved DSNU's 3 SE (Student's t for the fit's few dof) cover it."""
    rng = np.random.default_rng(11)
    t = np.array([0.0, 0.5, 1, 2, 4, 8])
    for D, min_limits in ((0.02, 100), (1.5, 0)):
        good = limits = 0
        for _ in range(200):
            s = np.sqrt(2.0**2 + (t * D) ** 2) * (1 + 0.02 * rng.standard_normal(t.size))
            f = dsnu_vs_exposure(t, s, 0.5)
            d = f.dsnu_dn_per_s
            assert f.dsnu_e_per_s.bound == d.bound and (d.bound or not d.available or d.se < d.value), d
            limits += d.bound == "upper"
            good += (d.value >= D if d.bound else abs(d.value - D) <= 3 * d.se) if d.available else 1
        assert good >= 195 and limits >= min_limits, (D, good, limits)


def test_doubling_temperature_log2_fit():
    rng = np.random.default_rng(4)
    T = np.array([20, 30, 40, 50, 60, 70])
    x = 12.0 * 2 ** ((T - 60) / 8.0) * (1 + 0.01 * rng.standard_normal(T.size))
    f = doubling_temperature(T, x, 0.01 * x)
    assert f.doubling_c.value == pytest.approx(8.0, rel=0.02)
    assert abs(f.doubling_c.value - 8.0) < 4 * f.doubling_c.se
    assert f.value_at_ref.value == pytest.approx(12.0, rel=0.03)


def _dark_series(rng, frames, jump_dn=0.0, rate=2.5, fg=0.2, t=np.linspace(0.01, 1.0, 8)):
    """Level means and frame means of a dark sweep whose frames carry a frame-global offset
    (``fg`` DN each frame) and, with ``jump_dn``, an offset that jumps at each stage change
    (a clamp settling anew with each exposure set)."""
    walk = rng.normal(0, jump_dn, t.size)
    fm = [64 + rate * x + w + rng.normal(0, fg, frames) for x, w in zip(t, walk)]
    return t, [float(np.mean(f)) for f in fm], fm


@pytest.mark.parametrize("frames", [2, 16])
def test_dark_current_se_from_the_frames_scatter_covers_the_truth(frames):
    """The dark mean's slope judged on the stacks' measured frame-to-frame scatter (issue 48):
    3 SE cover the truth on >= 99 % of sweeps. The 8 levels' residuals alone (no frame
    means: EMVA 1288 4.0 Section 7.1 as written) miss it on more than 1 % at 2 frames --
    a 2-frame dark current 7 SE off its truth, "ok", on the simulator."""
    rng = np.random.default_rng(48)
    miss = miss_resid = 0
    n = 400
    for _ in range(n):
        t, m, fm = _dark_series(rng, frames)
        r = dark_current(t, m, 0.28, frame_means=fm).rate_dn_per_s
        assert "frame-to-frame scatter" in r.note or "drifting" in r.note
        miss += abs(r.value - 2.5) > 3 * r.se
        e = dark_current(t, m, 0.28).rate_dn_per_s
        miss_resid += abs(e.value - 2.5) > 3 * e.se
    assert miss <= 0.01 * n
    if frames == 2:
        assert miss_resid > 0.01 * n  # (the reason for the rule: the residual SE of 6 dof without t)


def test_an_offset_jumping_between_stages_wins_over_the_frames_scatter():
    """Levels scattering about the line far more than their frames do (an offset that jumps
    at each stage change): the SE is the residuals', with Student's t, and the note says so;
    3 SE still cover the truth. (A drift that follows the exposure order is a slope no
    residual shows: interleave the exposures to see it.)"""
    rng = np.random.default_rng(7)
    notes, miss, n = 0, 0, 200
    for _ in range(n):
        t, m, fm = _dark_series(rng, 16, jump_dn=0.3)
        r = dark_current(t, m, 0.28, frame_means=fm).rate_dn_per_s
        notes += "drifting between stages" in r.note
        miss += abs(r.value - 2.5) > 3 * r.se
    assert notes >= 0.9 * n
    assert miss <= 0.03 * n
