"""The defect classifier over a wide injected family (tests/defect_family.py, issue 48):
per-class precision >= 95 % wherever a class is reported, against each pixel's truth set
(benchmarks/defect_family.md for the classes' meaning and the whole table); the telegraph
likelihood ratio's false-alarm rate measured on white series it was not calibrated on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ares.analysis.defects.rts import HMM_NULL_FRAMES, HMM_NULL_P, hmm_null_threshold, telegraph_lr
from defect_family import CLASSES, classify, make_case, score


def _precise(sc, min_given=1):
    bad = {c: (v["right"], v["given"], v["wrong"][:5]) for c, v in sc.items()
           if v["given"] >= min_given and v["right"] < 0.95 * v["given"]}
    assert not bad, bad
    for c, v in sc.items():
        if not v["available"]:
            assert v["verdict"], f"{c} not available without a reason"


def test_dense_case_every_class_precise_and_the_hard_pixels_right():
    """One dense (2 %) stack of 64 frames with K and the exposure: every reported class
    >= 95 % precise; a stuck pixel at code 0 is stuck, a noisy pixel in a bad column noisy,
    an RTS trap on a hot pixel rts or hot (its telegraph, or its rate)."""
    from ares.analysis.defects.result import PIXEL_CLASSES, primary_class

    case = make_case(40_642, 64, 2e-2, True, exposure_s=10.0)
    res = classify(case)
    sc = score(case, res)
    _precise(sc)
    assert sc["rts"]["found"] >= 0.6 * sc["rts"]["total"] and sc["noisy"]["found"] >= 0.9 * sc["noisy"]["total"]
    prim = primary_class(res.mask).ravel()
    name = lambda i: PIXEL_CLASSES[prim[i]] if prim[i] >= 0 else "good"  # noqa: E731
    hard = case.info["hard"]
    assert name(hard["stuck0"]) == "stuck"
    if hard["noisy_col"] is not None:
        assert name(hard["noisy_col"]) == "noisy", case.info
    for i in hard["rts_hot"]:
        assert case.excluded.ravel()[i] or name(i) in ("rts", "hot"), (i, name(i))


@pytest.mark.parametrize("seed, frames, di, pixels", [(2, 4, 2, (2417,)), (5, 16, 3, (381, 4094))])
def test_warm_with_k_not_claimed_where_the_series_is_no_steady_rate(seed, frames, di, pixels):
    """Tuning-seed stacks where warm (with K) was 92 % and 94 % precise: a noisy pixel whose 4
    frames put its mean 6.8 DN high; RTS traps of 2.9-5 sigma high in 10-13 of 16 frames
    (benchmarks/defect_family.md). Their series contradict a steady dark rate (a variance above
    the shot noise of their excess, a telegraph at p = 3e-3): not warm, but in the defect mask;
    the stack's true warm pixels keep their class."""
    from ares.analysis.defects.result import BITS, PIXEL_CLASSES, primary_class

    d = (1e-4, 1e-3, 5e-3, 2e-2)[di]
    case = make_case(seed * 1000 + frames * 10 + di, frames, d, True)
    res = classify(case)
    prim = primary_class(res.mask).ravel()
    for i in pixels:
        assert case.info["injected"][i] in ("noisy", "rts") and prim[i] != PIXEL_CLASSES.index("warm"), i
        assert res.defective().ravel()[i] and (res.mask.ravel()[i] & BITS["unclassified"] or prim[i] >= 0), i
    # a withheld pixel is no good pixel on any surface: listed, counted, in the total a limit sees
    unc = ((res.mask & BITS["unclassified"]) != 0).ravel() & (prim < 0)
    assert unc.any() and res.counts["unclassified"] == int(unc.sum())
    assert res.counts["total"] == sum(res.counts[c] or 0 for c in PIXEL_CLASSES) + res.counts["unclassified"] == len(res.defects)
    listed = set(zip(res.defects["y"][res.defects["cls"] == "unclassified"], res.defects["x"][res.defects["cls"] == "unclassified"]))
    assert listed == {divmod(int(i), res.mask.shape[1]) for i in np.flatnonzero(unc)}
    sc = score(case, res)
    assert sc["warm"]["right"] >= 1 and sc["hot"]["right"] == sc["hot"]["given"], sc["warm"]


def test_noisy_with_k_on_a_quiet_sensor_not_claimed_where_a_hidden_dark_signal_explains_it():
    """Issue 48: a quiet sensor (0.5 DN of noise and FPN, integer codes), 256 frames, K given --
    the tuning-seed stack where noisy was 35/39 precise: dark-rate pixels whose negative offset
    hides part of their excess read as noisy (their shot noise above K x the measured excess).
    Where the shot noise of a dark signal the excess does not rule out explains the variance,
    the pixel is not noisy but 'unclassified' (in the mask, listed, with the reason on the
    noisy verdict and in the notes); noisy >= 95 % precise, recall >= 85 % of the injected. Not
    where the data contradict K (the steady-rate check's note): the test trusts K."""
    from ares.analysis.defects.result import BITS, primary_class

    case = make_case(2 * 1000 + 256 * 10 + 3, 256, 2e-2, True, temporal=0.5)
    res = classify(case)
    sc = score(case, res)["noisy"]
    assert sc["available"] and sc["right"] >= 0.95 * sc["given"] and sc["found"] >= 0.85 * sc["total"], sc
    unc = ((res.mask & BITS["unclassified"]) != 0) & (primary_class(res.mask) < 0)
    assert res.counts["unclassified"] == int(unc.sum()) > 0
    assert "more 'unclassified'" in res.detection["noisy"] and "cannot tell" in res.detection["unclassified"]
    assert any("not noisy but 'unclassified'" in n for n in res.notes)
    # with a K the hot pixels' own variance contradicts (3x too high) the test trusts K no more than
    # the steady-rate check does: neither withholds
    from ares.analysis.defects import classify_stack

    wrong = classify_stack(case.dark, case.flat, gain_dn_per_e=1.5, exposure_s=case.exposure_s)
    assert any("check K" in n for n in wrong.notes) and not any("not noisy but" in n for n in wrong.notes)


def test_telegraph_ratio_false_alarm_rate_as_tabled():
    """White series the table was not made from reach the tabled threshold at p = 1e-2 with
    probability 1e-2 (within 4 binomial SE; at 34 frames, between two table rows: the larger
    threshold, at most p); the statistic is offset- and scale-free."""
    rng = np.random.default_rng(990_001)
    n, f = 6_000, 34
    assert f not in HMM_NULL_FRAMES
    lr = telegraph_lr(rng.standard_normal((f, n)))
    fa = float(np.mean(lr >= hmm_null_threshold(f, 1e-2)))
    assert 1e-2 - 4 * math.sqrt(1e-2 * 0.6 / n) - 2e-3 < fa < 1e-2 + 4 * math.sqrt(1e-2 / n), fa
    x = rng.standard_normal((f, 50))
    np.testing.assert_allclose(telegraph_lr(3.0 * x + 100.0), telegraph_lr(x), atol=1e-6)


def test_telegraph_ratio_without_numba_is_the_same_test(monkeypatch):
    """Without numba the telegraph ratio runs the numpy path of the same Baum-Welch (one
    kernel module holds both): the same decisions on white and telegraph series."""
    from ares.analysis.kernels import hmm

    rng = np.random.default_rng(990_002)
    f = 64
    state = (np.arange(f)[:, None] // 8 + np.arange(100)[None, :]) % 2
    x = np.concatenate([rng.standard_normal((f, 300)), 3.0 * state + rng.standard_normal((f, 100))], axis=1)
    fast = telegraph_lr(x)
    monkeypatch.setattr(hmm, "baum_welch", lambda *a, **k: None)
    slow = telegraph_lr(x)
    thr = hmm_null_threshold(f, 1e-3)
    assert np.mean((fast >= thr) == (slow >= thr)) >= 0.99 and np.mean(slow[300:] >= thr) > 0.9
    np.testing.assert_allclose(slow, fast, rtol=0.05, atol=0.5)


def test_telegraph_ratio_leaves_series_on_a_few_codes_untested():
    """White noise of 0.5 code steps rounded to integer codes sits on two or three codes: a
    two-state model fits that (84 % of such series of 64 frames reached the p = 1e-3 threshold):
    untested (NaN), in DN and in 12-bit codes stored MSB-aligned (steps of 16); from ~1 step the
    ratio is back at its nominal rate (a few % of 1.2-step series still untested), and a real telegraph of 4 steps on 1-step noise is found."""
    rng = np.random.default_rng(990_003)
    f = 64
    off = rng.uniform(0, 1, 2000)
    q = np.rint(100 + off + 0.5 * rng.standard_normal((f, 2000)))
    assert np.isnan(telegraph_lr(q)).mean() > 0.99 and np.isnan(telegraph_lr(16 * q)).mean() > 0.99
    w = np.rint(100 + off + 1.2 * rng.standard_normal((f, 2000)))
    lr = telegraph_lr(w)
    assert np.isnan(lr).mean() < 0.15 and np.mean(lr >= hmm_null_threshold(f, 1e-3)) < 4e-3
    state = (np.arange(f)[:, None] // 8 + np.arange(200)[None, :]) % 2  # dwell 8 frames
    t = np.rint(100 + 4.0 * state + rng.standard_normal((f, 200)))
    assert np.mean(telegraph_lr(t) >= hmm_null_threshold(f, 1e-3)) > 0.95


@pytest.mark.study
@pytest.mark.parametrize("frames", [4, 8, 16, 64, 256])
@pytest.mark.parametrize("with_gain", [True, False])
@pytest.mark.parametrize("seeds", [(101, 102, 103, 104, 105), (1, 2, 3, 4, 5)], ids=["held", "tune"])
def test_family_held_out_seeds_every_reported_class_precise(frames, with_gain, seeds, temporal=2.0):
    """Held-out seeds (101-105, not the tuning ones) and the tuning seeds over the four
    densities: summed over them, each class given to >= 10 pixels is >= 95 % precise; a
    class not available always says why."""
    tot = {c: [0, 0] for c in CLASSES}
    for seed in seeds:
        for di, d in enumerate((1e-4, 1e-3, 5e-3, 2e-2)):
            case = make_case(seed * 1000 + frames * 10 + di, frames, d, with_gain, temporal=temporal)
            sc = score(case, classify(case))
            for c, v in sc.items():
                tot[c][0] += v["right"]
                tot[c][1] += v["given"]
                assert v["available"] or v["verdict"], c
    bad = {c: f"{r}/{g}" for c, (r, g) in tot.items() if g >= 10 and r < 0.95 * g}
    assert not bad, (bad, tot)


@pytest.mark.study
@pytest.mark.parametrize("frames", [64, 256])
@pytest.mark.parametrize("with_gain", [True, False])
@pytest.mark.parametrize("seeds", [(101, 102, 103, 104, 105), (1, 2, 3, 4, 5)], ids=["held", "tune"])
@pytest.mark.parametrize("temporal", [0.3, 0.5])
def test_family_quiet_sensor_every_reported_class_precise(frames, with_gain, seeds, temporal):
    """The same on a quiet sensor (integer codes, 0.3 and 0.5 DN of noise and FPN): noisy with K at
    0.5 DN and 256 frames was 94 % (issue 48: a dark signal its offset hides, benchmarks/defect_family.md)."""
    test_family_held_out_seeds_every_reported_class_precise(frames, with_gain, seeds, temporal)


@pytest.mark.study
def test_telegraph_ratio_false_alarm_rate_every_table_row():
    """Every table row's p = 1e-3 threshold on 50 000 fresh white series: false-alarm rate
    1e-3 within 4 binomial SE."""
    rng = np.random.default_rng(990_002)
    n = 50_000
    for f in HMM_NULL_FRAMES[::4]:
        lr = np.concatenate([telegraph_lr(rng.standard_normal((f, 10_000))) for _ in range(n // 10_000)])
        fa = float(np.mean(lr >= hmm_null_threshold(f, HMM_NULL_P[-1])))
        assert abs(fa - 1e-3) < 4 * math.sqrt(1e-3 / n), (f, fa)
