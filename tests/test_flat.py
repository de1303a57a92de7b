"""Gain part: G, Cg, Rg, Pg, q, delta from flat + dark stacks (Monte Carlo, exact model)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ares.analysis.noise.accumulate import StackAccumulator
from ares.analysis.noise.decompose import COMPONENT_NAMES, StackAnalysis
from ares.analysis.noise.flat import decompose_flat, highpass_emva

F, R, C = 8, 40, 48
NREP = 200
DARK = dict(o=100.0, Pt=2.0, Rt=0.1, Ct=0.05, fg=0.1, Ps=1.0, Rs=0.2, Cs=0.3)
TRUTH = dict(G=0.5, q=2000.0, Cg=0.004**2, Rg=0.003**2, Pg=0.01**2)  # PRNU dominated


def make_patterns(rng, R=R, C=C, grad=0.0, realized=None):
    """(dark patterns, gain map, illumination); ``realized`` (a dict) receives the drawn gain
    patterns' variances (ddof=1), as the simulator's truth gives them."""
    dk = dict(
        Rs=rng.standard_normal(R) * math.sqrt(DARK["Rs"]),
        Cs=rng.standard_normal(C) * math.sqrt(DARK["Cs"]),
        Ps=rng.standard_normal((R, C)) * math.sqrt(DARK["Ps"]),
    )
    cg = 1 + rng.standard_normal(C) * math.sqrt(TRUTH["Cg"])
    rg = 1 + rng.standard_normal(R) * math.sqrt(TRUTH["Rg"])
    pg = 1 + rng.standard_normal((R, C)) * math.sqrt(TRUTH["Pg"])
    gain = cg[None, :] * rg[:, None] * pg
    if realized is not None:
        realized.update(Cg=float(cg.var(ddof=1)), Rg=float(rg.var(ddof=1)), Pg=float(pg.var(ddof=1)))
    yy, xx = np.meshgrid(np.linspace(-1, 1, R), np.linspace(-1, 1, C), indexing="ij")
    illum = 1 + grad * (0.6 * xx + 0.4 * yy - 0.5 * xx * xx)
    return dk, gain, illum


FLICKER = 0.003  # relative light-source fluctuation per frame (frame-global in the flat)


def render(rng, pats, n=F, q=0.0):
    dk, gain, illum = pats
    Rr, Cc = gain.shape
    x = DARK["o"] + dk["Rs"][:, None] + dk["Cs"][None, :] + dk["Ps"]
    x = np.broadcast_to(x, (n, Rr, Cc)).copy()
    x += rng.standard_normal((n, Rr, Cc)) * math.sqrt(DARK["Pt"])
    x += (rng.standard_normal((n, Rr)) * math.sqrt(DARK["Rt"]))[:, :, None]
    x += (rng.standard_normal((n, Cc)) * math.sqrt(DARK["Ct"]))[:, None, :]
    x += (rng.standard_normal(n) * math.sqrt(DARK["fg"]))[:, None, None]
    if q:
        qq = q * illum * (1 + FLICKER * rng.standard_normal(n))[:, None, None]
        e = qq + rng.standard_normal((n, Rr, Cc)) * np.sqrt(qq)  # Poisson, Gaussian approx.
        x += TRUTH["G"] * gain * e
    return x


def accs(rng, pats, q):
    a_d, a_f = StackAccumulator(pats[1].shape), StackAccumulator(pats[1].shape)
    a_d.add_batch(render(rng, pats))
    a_f.add_batch(render(rng, pats, q=q))
    return a_f, a_d


@pytest.mark.slow
@pytest.mark.parametrize("mode,grad", [("none", 0.0), ("surface", 0.1)])
def test_gain_components_unbiased(mode, grad, report):
    rng = np.random.default_rng(11 if mode == "none" else 12)
    keys = ("G", "Cg", "Rg", "Pg", "q", "delta")
    est = {k: [] for k in keys}
    se = {k: [] for k in keys}
    naive_g = []
    real = {k: [] for k in ("Cg", "Rg", "Pg")}  # each draw's own gain patterns
    for _ in range(NREP):
        one: dict = {}
        pats = make_patterns(rng, grad=grad, realized=one)
        for k in real:
            real[k].append(one[k])
        f, d = accs(rng, pats, TRUTH["q"])
        res = decompose_flat(f, d, illumination=mode)
        for k in keys:
            est[k].append(res[k].value)
            se[k].append(res[k].se)
        # naive gain: per-pixel temporal variance difference (holds Rt, Ct, fg)
        naive_g.append((f.temporal_var_map().mean() - d.temporal_var_map().mean()) / res["signal"].value)
    # truth for q and delta: mean photo-charge over the illumination
    illum_mean = make_patterns(np.random.default_rng(0), grad=grad)[2].mean()
    truth = dict(TRUTH, q=TRUTH["q"] * illum_mean, delta=TRUTH["q"] * illum_mean)
    report.append(f"\n[flat MC] illumination={mode} gradient={grad}: F={F} R={R} C={C}, {NREP} replicates")
    report.append(f"  {'comp':6s} {'truth':>11s} {'mean est':>11s} {'bias/SEM':>8s} {'SE ratio':>8s}")
    for k in keys:
        e, s = np.array(est[k]), np.array(se[k])
        sd = e.std(ddof=1)
        z = (e.mean() - truth[k]) / (sd / math.sqrt(NREP))
        # a gain pattern's SE is its measurement error, the draw's pattern held (anova.py)
        ratio = math.sqrt(np.mean(s**2)) / (np.std(e - np.array(real[k]), ddof=1) if k in real else sd)
        report.append(f"  {k:6s} {truth[k]:11.4g} {e.mean():11.4g} {z:8.2f} {ratio:8.3f}")
        tol_z = 3.0
        if k in ("q", "delta") and mode == "surface":
            tol_z = 4.0  # second-order gain x illumination products
        assert abs(z) < tol_z, (k, e.mean(), truth[k])
        assert abs(ratio - 1) < 0.15, (k, ratio)
    report.append(f"  naive G (per-pixel temporal variance difference): {np.mean(naive_g):.4g} "
                  f"(bias {np.mean(naive_g) / TRUTH['G'] - 1:+.1%}: light flicker counted as shot noise)")


def test_highpass_removes_gradient():
    """A 10 % illumination gradient: 'none' is badly biased, 'highpass' is close."""
    rng = np.random.default_rng(5)
    vals = {"none": [], "highpass": [], "surface": []}
    for _ in range(12):
        pats = make_patterns(rng, R=64, C=72, grad=0.1)
        f, d = accs(rng, pats, TRUTH["q"])
        for mode in vals:
            vals[mode].append({k: v.value for k, v in decompose_flat(f, d, illumination=mode).items()})
    for k in ("Cg", "Rg", "Pg"):
        hp = np.mean([v[k] for v in vals["highpass"]])
        sf = np.mean([v[k] for v in vals["surface"]])
        nn = np.mean([v[k] for v in vals["none"]])
        assert abs(hp / TRUTH[k] - 1) < 0.35, (k, hp, TRUTH[k])
        assert abs(sf / TRUTH[k] - 1) < 0.35, (k, sf, TRUTH[k])
        if k != "Pg":
            assert nn > 3 * TRUTH[k], (k, nn)


def test_highpass_kernel_is_emva_smoothing():
    img = np.zeros((41, 41))
    img[20, 20] = 1.0
    hp = highpass_emva(img)
    assert abs(hp.sum()) < 1e-6  # high-pass: zero DC gain (float32 between the filter passes)
    assert hp[20, 20] < 1 and hp[20, 20] > 0.95
    flat = np.full((30, 30), 7.0)
    assert np.allclose(highpass_emva(flat), 0)


def test_given_gain_poisson_check():
    rng = np.random.default_rng(8)
    pats = make_patterns(rng)
    f, d = accs(rng, pats, TRUTH["q"])
    res = decompose_flat(f, d, gain=TRUTH["G"], illumination="none")
    assert res["G"].is_exact and res["G"].se == 0  # given, not measured: exact, with its verdict
    pr = res["poisson_ratio"]
    assert abs(pr.value - 1) < 4 * pr.se
    assert abs(res["q"].value / TRUTH["q"] - 1) < 0.02


def test_dark_only_and_lazy():
    rng = np.random.default_rng(9)
    pats = make_patterns(rng)
    d = StackAccumulator((R, C))
    d.add_batch(render(rng, pats))
    an = StackAnalysis(d)
    m = an.signal_map
    assert m.shape == (R, C)
    assert an.computed == ["signal_map"]  # no ANOVA for a map
    comps = an.components()
    assert tuple(comps) == COMPONENT_NAMES
    for k in ("G", "Cg", "Rg", "Pg", "q", "delta"):
        assert not comps[k].available and comps[k].note == "dark stack: no gain components"
    assert "gain" not in an.computed
    assert comps["Pt"].available
    assert an.computed.count("dark_table") == 1
    an.components()
    assert an.computed.count("dark_table") == 1  # cached


def test_flat_analysis_facade():
    rng = np.random.default_rng(10)
    pats = make_patterns(rng)
    f, d = accs(rng, pats, TRUTH["q"])
    an = StackAnalysis(d, f, illumination="none")
    comps = an.components()
    assert abs(comps["G"].value / TRUTH["G"] - 1) < 5 * comps["G"].se / TRUTH["G"]
    assert an.extras()["signal"].unit == "DN"
    e = an.in_electrons()
    assert e["Pt"].unit == "e-^2"


@pytest.mark.slow
def test_highpass_mode_unbiased_with_gradient(report):
    """EMVA 4.0 high-pass with a 10 % illumination gradient: kernel-corrected variances."""
    rng = np.random.default_rng(21)
    n = 100
    est = {k: [] for k in ("Cg", "Rg", "Pg")}
    se = {k: [] for k in est}
    real = {k: [] for k in est}
    for _ in range(n):
        one: dict = {}
        pats = make_patterns(rng, R=72, C=80, grad=0.1, realized=one)
        f, d = accs(rng, pats, TRUTH["q"])
        res = decompose_flat(f, d, illumination="highpass")
        for k in est:
            est[k].append(res[k].value)
            se[k].append(res[k].se)
            real[k].append(one[k])
    report.append(f"\n[flat MC] illumination=highpass gradient=0.1: F={F} R=72 C=80, {n} replicates")
    for k in est:
        e, s = np.array(est[k]), np.array(se[k])
        sd = e.std(ddof=1)
        z = (e.mean() - TRUTH[k]) / (sd / math.sqrt(n))
        ratio = math.sqrt(np.mean(s**2)) / np.std(e - np.array(real[k]), ddof=1)  # the draw's pattern held
        report.append(f"  {k:6s} {TRUTH[k]:11.4g} {e.mean():11.4g} {z:8.2f} {ratio:8.3f}")
        assert abs(z) < 3.5, (k, z)  # approximate mode: kernel factors assume white effects
        assert abs(ratio - 1) < 0.2, (k, ratio)


def test_flat_not_estimable_and_errors():
    from ares.errors import InputError

    rng = np.random.default_rng(13)
    pats = make_patterns(rng)
    d1, f1 = StackAccumulator((R, C)), StackAccumulator((R, C))
    d1.add(render(rng, pats, n=1)[0])
    f1.add(render(rng, pats, n=1, q=TRUTH["q"])[0])
    res = decompose_flat(f1, d1, illumination="none")
    for k in ("G", "Cg", "Rg", "Pg", "q", "delta"):
        assert not res[k].available and res[k].note.startswith("needs >= 2")
    f, d = accs(rng, pats, TRUTH["q"])
    small = decompose_flat(f, d, illumination="highpass")  # 40 x 48 is enough
    assert small["Pg"].available
    tiny_f, tiny_d = StackAccumulator((10, 12)), StackAccumulator((10, 12))
    tiny_f.add_batch(render(rng, pats, q=TRUTH["q"])[:, :10, :12])
    tiny_d.add_batch(render(rng, pats)[:, :10, :12])
    hp = decompose_flat(tiny_f, tiny_d, illumination="highpass")
    assert not hp["Pg"].available and "high-pass" in hp["Pg"].note
    assert hp["G"].available
    with pytest.raises(InputError, match="illumination"):
        decompose_flat(f, d, illumination="flat")
    with pytest.raises(InputError, match="differ in shape"):
        decompose_flat(tiny_f, d)


def test_highpass_autocorrelation_equals_scipy_correlate2d():
    """The numpy 2-D autocorrelation behind the 4.0 high-pass factors is scipy's correlate2d
    (full mode) to float rounding, on the real kernel and on an asymmetric one."""
    import numpy as np
    from scipy.signal import correlate2d

    from ares.analysis.noise import flat

    h2 = -np.outer(flat._L1, flat._L1)
    h2[flat._RAD, flat._RAD] += 1.0
    rng = np.random.default_rng(0)
    for h in (h2, rng.standard_normal((5, 7))):
        ours = flat._autocorrelation_2d(h)
        ref = correlate2d(h, h)
        assert ours.shape == ref.shape
        assert np.allclose(ours, ref, rtol=0, atol=1e-14 * np.abs(ref).max())


@pytest.mark.parametrize("mode", ["highpass", "none", "surface"])
def test_flat_equal_to_its_dark_is_not_available(mode):
    """The light never came on: the flat stack is the dark stack. The gain non-uniformity has
    no signal to be relative to -- 'not available' with the reason, never a division by zero."""
    rng = np.random.default_rng(5)
    frames = render(rng, make_patterns(rng))
    f, d = StackAccumulator((R, C)), StackAccumulator((R, C))
    f.add_batch(frames)
    d.add_batch(frames)
    res = decompose_flat(f, d, illumination=mode)
    for k in ("Cg", "Rg", "Pg"):
        assert not res[k].available and "no signal above dark" in res[k].note, res[k]
