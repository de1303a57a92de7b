"""Monte Carlo: the three-way ANOVA is unbiased and its standard errors are right.

A small local generator draws the exact random-effects model (no simulator needed), in
several regimes; 200+ replicates each. Next to every ANOVA figure the report shows the
bias of the naive estimators (temporal variance of row means as "row temporal noise",
EMVA-style row/column split of the mean image).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ares.analysis.noise.accumulate import StackAccumulator
from ares.analysis.noise.anova import DARK_NAMES, anova_table, decompose_dark, in_electrons, sigma_view

F, R, C = 8, 32, 40
NREP = 220

REGIMES = {
    "read-noise dominated": dict(Pt=4.0, Rt=0.05, Ct=0.03, frame_global=0.2, Ps=0.6, Rs=0.1, Cs=0.15),
    "row-noise heavy": dict(Pt=1.0, Rt=0.8, Ct=0.02, frame_global=0.1, Ps=0.3, Rs=0.4, Cs=0.1),
    "strong column FPN": dict(Pt=2.0, Rt=0.05, Ct=0.2, frame_global=0.05, Ps=0.5, Rs=0.05, Cs=6.0),
    "frame-global + DSNU": dict(Pt=1.5, Rt=0.1, Ct=0.05, frame_global=2.0, Ps=3.0, Rs=0.2, Cs=0.3),
}


def draw(rng, p, F=F, R=R, C=C, o=100.0, realized=None):
    """One stack of the exact random-effects model (float64, frames x rows x cols);
    ``realized`` (a dict) receives this draw's pattern variances (ddof=1: Rs over the rows,
    Cs over the columns, Ps over every pixel), as the simulator's truth gives them."""
    s = {k: math.sqrt(v) for k, v in p.items()}
    x = rng.standard_normal((F, R, C)) * s["Pt"]
    x += o
    x += (rng.standard_normal(F) * s["frame_global"])[:, None, None]
    rs, cs = rng.standard_normal(R) * s["Rs"], rng.standard_normal(C) * s["Cs"]
    x += rs[None, :, None]
    x += cs[None, None, :]
    x += (rng.standard_normal((F, R)) * s["Rt"])[:, :, None]
    x += (rng.standard_normal((F, C)) * s["Ct"])[:, None, :]
    ps = rng.standard_normal((R, C)) * s["Ps"]
    x += ps[None, :, :]
    if realized is not None:
        realized.update(Rs=float(rs.var(ddof=1)), Cs=float(cs.var(ddof=1)), Ps=float(ps.var(ddof=1)))
    return x


def naive(x):
    """Biased textbook estimators, for the report."""
    Fx = x.shape[0]
    row_means = x.mean(axis=2)  # (F, R)
    col_means = x.mean(axis=1)
    tvar = x.var(axis=0, ddof=1).mean()
    mean_img = x.mean(axis=0)
    # EMVA 1288-style split of the mean image: row variance minus the temporal part /F
    # assuming white temporal noise, minus the pixel part / C
    resid = mean_img - mean_img.mean(1, keepdims=True) - mean_img.mean(0, keepdims=True) + mean_img.mean()
    s2_pix = resid.var(ddof=1) * (R * C - 1) / ((R - 1) * (C - 1)) - tvar / Fx
    rows = mean_img.mean(axis=1).var(ddof=1) - tvar / (Fx * C) - s2_pix / C
    cols = mean_img.mean(axis=0).var(ddof=1) - tvar / (Fx * R) - s2_pix / R
    return {
        "Rt": row_means.var(axis=0, ddof=1).mean(),  # temporal var of row means
        "Ct": col_means.var(axis=0, ddof=1).mean(),
        "Pt": tvar,  # per-pixel temporal variance
        "Rs": rows,
        "Cs": cols,
        "Ps": s2_pix,
    }


@pytest.mark.slow
@pytest.mark.parametrize("regime", list(REGIMES))
def test_unbiased_and_se(regime, report):
    p = REGIMES[regime]
    rng = np.random.default_rng(1234 + list(REGIMES).index(regime))
    est = {k: [] for k in DARK_NAMES}
    se = {k: [] for k in DARK_NAMES}
    nv = {k: [] for k in ("Rt", "Ct", "Pt", "Rs", "Cs", "Ps")}
    real = {k: [] for k in ("Rs", "Cs", "Ps")}  # this draw's pattern variances
    for _ in range(NREP):
        one: dict = {}
        x = draw(rng, p, realized=one)
        for k in real:
            real[k].append(one[k])
        acc = StackAccumulator((R, C))
        acc.add_batch(x)
        d = decompose_dark(acc)
        for k in DARK_NAMES:
            est[k].append(d[k].value)
            se[k].append(d[k].se)
        for k, v in naive(x).items():
            nv[k].append(v)
    report.append(f"\n[ANOVA MC] {regime}: F={F} R={R} C={C}, {NREP} replicates")
    report.append(f"  {'comp':13s} {'truth':>8s} {'mean est':>9s} {'bias/SEM':>8s} {'SE ratio':>8s} {'naive':>9s} {'naive bias':>10s}")
    for k in DARK_NAMES:
        if k == "o":
            continue
        e = np.array(est[k])
        s = np.array(se[k])
        sd = e.std(ddof=1)
        sem = sd / math.sqrt(NREP)
        z = (e.mean() - p[k]) / sem
        # a pattern's SE is its measurement error, this sensor's pattern held (anova.py): against
        # the draw's own pattern variance; a temporal one's against the parameter
        ratio = math.sqrt(np.mean(s**2)) / (np.std(e - np.array(real[k]), ddof=1) if k in real else sd)
        nmean = f"{np.mean(nv[k]):9.4f} {np.mean(nv[k]) / p[k] - 1:+10.0%}" if k in nv else ""
        report.append(f"  {k:13s} {p[k]:8.4f} {e.mean():9.4f} {z:8.2f} {ratio:8.3f} {nmean}")
        assert abs(z) < 3, (regime, k, e.mean(), p[k], sem)
        assert abs(ratio - 1) < 0.15, (regime, k, ratio)


def test_offset_and_units():
    rng = np.random.default_rng(7)
    p = REGIMES["read-noise dominated"]
    x = draw(rng, p, o=250.0)
    acc = StackAccumulator((R, C))
    acc.add_batch(x)
    d = decompose_dark(acc)
    assert d["o"].unit == "DN" and d["Pt"].unit == "DN^2"
    assert abs(d["o"].value - x.mean()) < 1e-9
    assert d["o"].se > 0
    e = in_electrons(d, 0.5)
    assert e["Pt"].unit == "e-^2" and math.isclose(e["Pt"].value, d["Pt"].value / 0.25)
    assert math.isclose(e["o"].value, d["o"].value / 0.5)
    s = sigma_view(d)
    assert math.isclose(s["Pt"].value, math.sqrt(d["Pt"].value))
    assert s["Pt"].unit == "DN"


def test_matches_direct_anova():
    """Streaming sums give the same SS as a direct computation on the cube."""
    rng = np.random.default_rng(3)
    x = np.round(draw(rng, REGIMES["row-noise heavy"], F=5, R=7, C=9) * 10).astype(np.int64) + 1000
    acc = StackAccumulator((7, 9))
    acc.add_batch(x.astype(np.uint16))
    tab = anova_table(acc)
    xf = x.astype(float)
    m = xf.mean()
    mf, mr, mc = xf.mean((1, 2)), xf.mean((0, 2)), xf.mean((0, 1))
    mfr, mfc, mrc = xf.mean(2), xf.mean(1), xf.mean(0)
    e = (
        xf - mfr[:, :, None] - mfc[:, None, :] - mrc[None] + mf[:, None, None] + mr[None, :, None] + mc[None, None, :] - m
    )
    assert math.isclose(tab.ss["E"], (e**2).sum(), rel_tol=1e-9)
    assert math.isclose(tab.ss["FR"], 9 * ((mfr - mf[:, None] - mr[None] + m) ** 2).sum(), rel_tol=1e-9)
    assert math.isclose(tab.ss["C"], 5 * 7 * ((mc - m) ** 2).sum(), rel_tol=1e-9)


@pytest.mark.parametrize(
    "shape,nf,missing",
    [((8, 9), 1, "frames"), ((1, 9), 4, "rows"), ((8, 1), 4, "columns")],
)
def test_not_estimable_is_na(shape, nf, missing):
    rng = np.random.default_rng(0)
    acc = StackAccumulator(shape)
    acc.add_batch(rng.integers(0, 100, (nf,) + shape).astype(np.uint16))
    d = decompose_dark(acc)
    assert d["o"].available
    for k in DARK_NAMES[1:]:
        assert not d[k].available, k
        assert d[k].note == f"needs >= 2 {missing}", d[k].note


def test_the_table_is_kept_by_the_accumulator_until_frames_arrive():
    """A stage's analysis (and a matched dark reused at every stage) asks for the same
    table several times: the accumulator keeps it, equal to a fresh one, and computes it
    anew once more frames are added."""
    from ares.analysis.noise import anova

    rng = np.random.default_rng(5)
    frames = rng.integers(100, 200, size=(10, 12, 14)).astype(np.uint16)
    acc = StackAccumulator((12, 14))
    acc.add_batch(frames[:6])
    t1 = anova_table(acc)
    assert anova_table(acc) is t1
    fresh = StackAccumulator((12, 14))
    fresh.add_batch(frames[:6])
    assert anova._table(fresh).ss == t1.ss and anova._table(fresh).df == t1.df
    acc.add_batch(frames[6:])
    t2 = anova_table(acc)
    assert t2 is not t1 and t2.F == 10
    fresh.add_batch(frames[6:])
    assert anova._table(fresh).ss == t2.ss
