"""Photon counting over the validation corpus (issue 48 (d), tests/pc_corpus.py): simulator
stacks over K 2-30 DN/e-, read noise 0.1-0.5 e-, 0.05-2 e-/pixel, fitted with their dark
stack as ``ares photon-counting`` fits them. The cases that failed before: read noise 0.15 e-
at K 10-20 (the best-separated peaks) gave "not available: read noise too high" in 7 of 8
sets (the comb search stopped at twice the values' spread, shorter than K at low light), and
K 20, 0.45 e-, 0.1 e-/pixel was 2.6 % off at 2.7 SE "ok". The fast test takes one seed of a
stratified handful; the study the whole grid over several seeds (benchmarks/
photon_counting_corpus.md has its table)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from pc_corpus import CHARGES, GAINS, READ_NOISES, run_case

# (30, 0.3, 2): its fit takes ~2.5 s (many peaks, every start refined); the grid covers it in the study
STRATA = [(10.0, 0.15, 0.05), (20.0, 0.15, 0.1), (2.0, 0.1, 0.5), pytest.param(30.0, 0.3, 2.0, marks=pytest.mark.study),
          (5.0, 0.45, 0.5), (20.0, 0.45, 0.1)]


@pytest.mark.parametrize("K,rn,H", STRATA)
def test_stratified_cases_against_truth(K, rn, H):
    r = run_case(K, rn, H, seed=11, frames=20, size=64)
    assert r["available"], r["note"]
    assert abs(r["k_err"]) < 3.5 * r["k_se"], r  # the SE covers the error
    # never a wrong "ok": an "ok" K is within 0.5 % (3 SE within it); one whose 3 SE exceed it
    # says so, with the values it needs (more than these)
    if r["k_verdict"] == "ok":
        assert abs(r["k_err"]) < 0.005 and 3 * r["k_se"] <= 0.005, r
    else:
        assert r["k_verdict"] == "precision not enough" and r["k_needs_values"] > r["values"], r
    if rn <= 0.3 and H >= 0.05:  # well separated: the targets at 164 000 values already
        assert abs(r["k_err"]) < 0.005, r
        if np.isfinite(r["rn_err"]):
            assert abs(r["rn_err"]) < 0.03, r
    if r["rn_bound"] == "":
        assert abs(r["rn_err"]) < 3.5 * r["rn_se"], r


def test_merged_peaks_are_not_available():
    r = run_case(10.0, 0.9, 1.0, seed=3, frames=20, size=64)
    assert not r["available"] and ("too high for separated peaks" in r["note"] or "not resolved" in r["note"]
                                   or "does not describe" in r["note"]), r


@functools.lru_cache(maxsize=1)
def _grid():
    """Each cell its own seeds (cells sharing seeds share their draws: their errors correlate)."""
    cells = [(K, rn, H) for K in GAINS for rn in READ_NOISES for H in CHARGES]
    return [run_case(K, rn, H, 5000 + 10 * i + s, frames=40, size=96) for i, (K, rn, H) in enumerate(cells)
            for s in range(3)]


@pytest.mark.study
def test_whole_grid_over_seeds():
    """Every case of the grid is available; K within max(0.5 %, 3.5 SE) and read noise within
    max(3 %, 3.5 SE) of the truth on >= 97 % of the cases (no case off by more than 4 %)."""
    rows = _grid()
    na = [r for r in rows if not r["available"]]
    assert not na, na[:5]
    k_ok = [abs(r["k_err"]) <= max(0.005, 3.5 * r["k_se"]) for r in rows]
    rn_ok = [abs(r["rn_err"]) <= max(0.03, 3.5 * r["rn_se"]) for r in rows if np.isfinite(r["rn_err"])]
    assert np.mean(k_ok) >= 0.97 and np.mean(rn_ok) >= 0.97, (np.mean(k_ok), np.mean(rn_ok))
    assert max(abs(r["k_err"]) for r in rows) < 0.04


@pytest.mark.study
def test_no_wrong_ok_over_the_grid():
    """Issue 48: every K the fit calls "ok" is within 0.5 % of the truth (the K 20, 0.45 e-,
    0.1 e-/pixel case was 2.6 % off at 2.7 SE "ok"); the others say "precision not enough"
    and are within max(0.5 %, 3.5 SE)."""
    rows = [r for r in _grid() if r["available"]]
    bad = [r for r in rows if r["k_verdict"] == "ok" and abs(r["k_err"]) > 0.005]
    assert not bad, bad[:3]
    flagged = [r for r in rows if r["k_verdict"] != "ok"]
    assert all(r["k_verdict"] == "precision not enough" and r["k_needs_values"] > r["values"] for r in flagged)
    assert all(abs(r["k_err"]) <= max(0.005, 3.5 * r["k_se"]) for r in flagged)


@pytest.mark.study
def test_the_frames_a_flagged_fit_asks_for_reach_the_target():
    """As a lab would: a low-light case flagged at 20 frames, taken again with the frames its
    verdict asks for (same seed), is "ok" and within 0.5 %."""
    r = run_case(20.0, 0.45, 0.1, seed=11, frames=20, size=64)
    assert r["k_verdict"] == "precision not enough", r
    f = int(np.ceil(20 * r["k_needs_values"] / r["values"]))
    r2 = run_case(20.0, 0.45, 0.1, seed=11, frames=f, size=64)
    assert r2["k_verdict"] == "ok" and abs(r2["k_err"]) < 0.005, (f, r2)


@pytest.mark.study
def test_spread_over_se_within_the_target_band():
    """The SEs describe the scatter: error / SE of K and of the read noise, pooled over each
    read noise's 60 cases (independent seeds), spread 0.8-1.25 (benchmark: 0.86-1.13)."""
    rows = _grid()
    for rn in READ_NOISES:
        z = np.array([r["k_err"] / r["k_se"] for r in rows if r["rn"] == rn and r["available"]])
        assert 0.8 <= z.std(ddof=1) <= 1.25, (rn, z.std(ddof=1))
        z = np.array([r["rn_err"] / r["rn_se"] for r in rows if r["rn"] == rn and np.isfinite(r["rn_se"])])
        assert 0.8 <= z.std(ddof=1) <= 1.25, ("read noise", rn, z.std(ddof=1))
