"""Never a wrong "ok" in photon transfer (issue 48): decisions on the measured scatter, the
headline gain by physics and evidence, a turnoff that holds, sanity as a verdict, the
linearity ramp's turnoff -- against truth (a generated corpus with known answers, the
simulator's sensor in closed form, LSST's published ComCam ramp).

The full corpus (2000 curves) and the simulator study are in ``test_ptc_study.py``
(``@pytest.mark.study``); here a stratified 96-curve subset keeps the suite fast."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from ares.analysis.ptc.levels import LevelStats
from ares.analysis.ptc.photon_transfer import analyze_ptc
from ares.analysis.ptc.ramp import ramp_turnoff
from ares.analysis.ptc.turnoff import decision_errors, ptc_turnoff
from ares.analysis.stats.scatter import measured_scatter
from ares.cli import main

from ptc_corpus import case, run_case, stratified
from ptc_synth import make_levels

COMCAM = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "cppipe-comcam-linearity" / \
    "comcam_linearity.csv"
# published (cp_pipe tests/test_linearity.py, test_linearity_turnoff; SOURCE.txt)
COMCAM_TURNOFF, COMCAM_MAX = 99756.30512572, 108730.32842316


def _json(capsys, args) -> dict:
    assert main(args) == 0
    return json.loads(capsys.readouterr().out)


# ------------------------------------------------------------------ the ComCam ramp

needs_comcam = pytest.mark.skipif(not COMCAM.is_file(), reason=f"public ComCam ramp not found at {COMCAM}")


@needs_comcam
def test_comcam_ramp_turnoff_and_max_signal_within_1_percent(capsys):
    d = _json(capsys, ["ptc", str(COMCAM), "--json"])
    to, mx = d["linearity_turnoff_dn"], d["max_signal_dn"]
    assert to["verdict"] == "ok" and abs(to["value"] - COMCAM_TURNOFF) <= 0.01 * COMCAM_TURNOFF, to
    assert mx["verdict"] == "ok" and abs(mx["value"] - COMCAM_MAX) <= 0.01 * COMCAM_MAX, mx
    assert d["linearity_turnoff_level"] == "line 92"  # index 90, as published
    assert to["se"] > 0 and "cp_pipe" in to["note"]


@needs_comcam
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_comcam_ramp_shuffled_and_thinned_holds(capsys, tmp_path, seed):
    rows = list(csv.DictReader(open(COMCAM)))
    rng = np.random.default_rng(seed)
    drop = set(rng.choice([i for i in range(len(rows)) if i not in (89, 90, 91)], 2, replace=False).tolist())
    keep = [rows[i] for i in rng.permutation(len(rows)) if i not in drop]
    p = tmp_path / "ramp.csv"
    with open(p, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["monitor", "mean"])
        w.writerows([[r["photo_charge_C"], r["raw_mean_adu"]] for r in keep])
    d = _json(capsys, ["ptc", str(p), "--json"])
    assert abs(d["linearity_turnoff_dn"]["value"] - COMCAM_TURNOFF) <= 0.01 * COMCAM_TURNOFF


@needs_comcam
def test_ramp_that_never_saturates_gives_a_lower_limit(capsys, tmp_path):
    rows = list(csv.DictReader(open(COMCAM)))[:80]
    p = tmp_path / "ramp.csv"
    with open(p, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["exposure", "mean"])
        w.writerows([[float(r["photo_charge_C"]) * 1e9, r["raw_mean_adu"]] for r in rows])
    d = _json(capsys, ["ptc", str(p), "--json"])
    assert d["linearity_turnoff_dn"]["verdict"] == "lower limit"
    assert "does not reach saturation" in d["linearity_turnoff_dn"]["note"]


def test_ramp_turnoff_of_a_closed_form_ramp():
    x = np.linspace(1, 100, 60)
    y = 1000 * x
    y[x > 70] = 70000 + 200 * (x[x > 70] - 70)  # saturating beyond x = 70
    r = ramp_turnoff(x, y)
    assert r.reached and r.turnoff == pytest.approx(1000 * x[x <= 70].max())
    assert r.max_signal == pytest.approx(np.median(y[y > 0.99 * y.max()]))


# ------------------------------------------------------------- measured scatter

@pytest.mark.parametrize("factor", [0.3, 1.0, 3.0])
def test_measured_scatter_against_claimed_errors(factor):
    rng = np.random.default_rng(4)
    x = np.sort(rng.uniform(10, 5e4, 300))
    y = 0.3 * x + 20 - 1e-6 * x * x
    e = 0.01 * y
    sc = measured_scatter(x, y + factor * e * rng.standard_normal(x.size), e)
    assert sc.ratio == pytest.approx(factor, rel=0.25)
    assert sc.disagree == (factor != 1.0)


def test_counts_that_overstate_the_precision_lose_to_the_scatter_and_the_result_says_so():
    S = np.geomspace(20, 2e4, 60)
    V = 0.5 * S + 10
    rng = np.random.default_rng(1)
    Vm = V * (1 + 0.02 * rng.standard_normal(S.size))  # 2 % scatter
    de = decision_errors(S, Vm, 0.002 * V)  # counts claiming 0.2 %
    assert de.source == "measured" and "measured scatter is used" in de.note
    assert np.median(de.se / V) == pytest.approx(0.02, rel=0.3)
    de = decision_errors(S, Vm, 0.02 * V)
    assert de.source == "counts"


def test_linearity_verdict_decides_on_the_measured_scatter():
    """A straight PTC with 5 % per-level scatter whose counts claim 0.5 %: its local slopes
    scatter 3.6 % about K, which the counts' errors call non-linear; the measured scatter
    (14x the claimed) sets the noise floor, the linear model holds, and the note says so."""
    from ares.analysis.ptc.fit import local_slope_check

    S = np.geomspace(100, 5e4, 40)
    V = 0.5 * S + 20
    Vm = V * (1 + 0.05 * np.random.default_rng(4).standard_normal(S.size))
    r = local_slope_check(S, Vm, 0.005 * V, 0.5)
    assert r.mean_rel_dev > 0.03 and r.holds is True, r
    assert "errors from the measured scatter" in r.note and "counts' errors" in r.note, r.note
    r = local_slope_check(S, Vm, None, 0.5)  # no errors at all: the measured scatter alone
    assert r.holds is True and "x the variance" in r.note, r.note
    bent = 0.5 * S * (1 - S / 2e5)  # a real 12 % flattening is still seen
    r = local_slope_check(S, bent * (1 + 0.003 * np.random.default_rng(1).standard_normal(S.size)), 0.003 * bent, 0.5)
    assert r.holds is False, r


# ------------------------------------------------------------------ the turnoff

def test_turnoff_is_linear_prefix_fit_equivalent_on_a_clean_curve():
    S = np.linspace(10, 1e4, 400)
    V = 0.4 * S + 5
    V[S > 8000] *= np.maximum(1 - 4 * (S[S > 8000] - 8000) / 8000, 0.05)
    n = ptc_turnoff(S, V, 0.005 * V)
    assert S[n - 1] == pytest.approx(S[S <= 8000].max())


def test_turnoff_never_at_the_first_levels_on_a_few_standard_errors():
    S = np.geomspace(2, 3000, 25)
    V = 0.28 * S + 0.01
    V[3] *= 0.97  # a level 3 % low, with errors claiming 0.5 %: not the end of the curve
    assert ptc_turnoff(S, V, 0.005 * V) == 25


@pytest.mark.parametrize("frac", [0.3, 0.5, 0.7])
def test_a_wild_row_before_the_turnover_is_no_top_to_fall_below(frac):
    """One row 30 % above a dense curve (1.5 % scatter) before its turnover -- an outlier of
    heavy-tailed scatter: a cosmic ray in a flat pair, a flicker. The levels after it lie on
    the curve, below that row by many SE: before, they "departed below the highest variance"
    and the turnoff was the outlier's level (30-70 % of the truth, "ok")."""
    S = np.linspace(10, 1e4, 300)
    V = (0.4 * S + 5) * (1 + 0.015 * np.random.default_rng(3).standard_normal(S.size))
    V[S > 8000] *= np.maximum(1 - 4 * (S[S > 8000] - 8000) / 8000, 0.05)
    V[int(np.searchsorted(S, frac * 8000))] *= 1.3
    n = ptc_turnoff(S, V, 0.015 * (0.4 * S + 5))
    assert S[n - 1] == pytest.approx(S[S <= 8000].max(), rel=0.03)


@pytest.mark.parametrize("i, seed", [(85, 0), (830, 0), (1343, 0), (1866, 1)])
def test_heavy_tailed_scatter_gives_no_absurd_or_wrong_ok(tmp_path, i, seed):
    """Corpus curves with Student's t (3 dof) per-level noise, a family the rules were not
    developed on (``ptc_corpus.case(tails="t3")``): each gave an "ok" turnoff 1.5-14x below
    the truth (a wild row before the turnover -- 9 SE but only 8.6 % high on seed 1 curve 1866
    -- taken for the top of the curve); now "ok" and within 3 % (benchmarks/ptc_corpus.md,
    "Heavy-tailed scatter")."""
    c = case(i, seed, tails="t3")
    d, j = run_case(c, tmp_path)
    assert not j["absurd"], j["absurd"]
    assert d["turnoff_dn"]["verdict"] != "ok" or j["turnoff"], (d["turnoff_dn"], c.truth["turnoff_dn"])


def _gentle(tmp_path, top: float, n: int = 200) -> dict:
    """``ares ptc`` on a curve turning at 30 000 DN (K 1) whose slope then falls 1.5 per unit
    of relative signal (the variance still rising: a gentle roll-off the fits below take for
    a brighter-fatter bend), 3 % per-level noise, levels up to ``top`` x the turnoff."""
    from ares.commands.ptc import analyse_table

    S = np.linspace(0.02, top, n) * 30000.0
    r = np.maximum(S - 30000.0, 0) / 30000.0
    V = np.where(r > 0, 30000.0 + (S - 30000.0) * (1 - 0.75 * r), S) + 25.0
    V *= 1 + 0.03 * np.random.default_rng(0).standard_normal(n)
    path = tmp_path / "gentle.csv"
    path.write_text("mean,var\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(S, V)))
    return analyse_table(path)[1]


def test_a_gentle_rolloff_is_no_lower_limit_and_a_curve_below_its_turnoff_keeps_it(tmp_path):
    # the top levels fit a turnover better than one smooth curve: "not available" with the
    # interval, not "saturation not reached" at 45 000 DN (it was, before the test of the top)
    to = _gentle(tmp_path, 1.5)["turnoff_dn"]
    assert to["verdict"] == "not available" and "saturation may be reached" in to["note"]
    lo = float(to["note"].split("turning between ")[1].split(" and ")[0])
    assert lo <= 30000 * 1.03
    # the same curve cut below its turnoff still gives its lower limit, at its top level
    to = _gentle(tmp_path, 0.98)["turnoff_dn"]
    assert to["verdict"] == "lower limit" and to["value"] == pytest.approx(0.98 * 30000)


def test_a_sparse_gentle_rolloff_confirmed_late_is_no_ok(tmp_path):
    # 16 log-spaced levels, the curve turning at 30 000 DN (its last level on the curve:
    # 22 400 DN), the slope then falling 1.5 per unit of relative signal, 0.5 % noise: the
    # departure is confirmed only at the top level, and the turnoff was "ok" at 29 900 DN
    # (+33 %); the levels up to it fit a turnover below it, so it is "not available" with
    # an interval reaching the true last level
    from ares.commands.ptc import analyse_table

    S = np.geomspace(0.02, 1.5, 16) * 30000.0
    r = np.maximum(S - 30000.0, 0) / 30000.0
    V = (np.where(r > 0, 30000.0 + (S - 30000.0) * (1 - 0.75 * r), S) + 25.0) * (
        1 + 0.005 * np.random.default_rng(0).standard_normal(16))
    path = tmp_path / "sparse_gentle.csv"
    path.write_text("mean,var\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(S, V)))
    to = analyse_table(path)[1]["turnoff_dn"]
    assert to["verdict"] == "not available", to
    lo = float(to["note"].split("only between ")[1].split(" and ")[0])
    assert lo <= 1.03 * S[S <= 30000.0][-1]


def _sim_like(frames: int, seed: int):
    """Levels like the shipped simulator's main job: K 0.28 DN/e-, full well 12 000 e-,
    read noise 3.6 e-, 307 200 pixels, 25 log-spaced levels, the last five beyond full
    well; the signal's error from ``frames`` frame means (1 degree of freedom at 2)."""
    mu = np.geomspace(6.4, 64000, 25)
    b, d, t = make_levels(mu, K=0.28, fw_e=12000, prnu=0.005, read_e=3.6, offset=64, n_pixels=307200,
                          frames=frames, seed=seed)
    rng = np.random.default_rng(seed)
    sse = 0.1 * np.sqrt(rng.chisquare(frames - 1, 25) / (frames - 1))
    for i in range(25):  # the frame means scatter by the offset noise: the means carry it
        b[i] = LevelStats(b[i].mean + 0.1 * rng.standard_normal(), b[i].var, b[i].n_pixels, frames,
                          b[i].frac_at_max, b[i].frac_at_min, b[i].spatial_var)
    return b, d, sse


@pytest.mark.parametrize("frames,seed", [(2, 2), (2, 5), (4, 1), (16, 3)])
def test_simulator_like_levels_give_k_and_full_well(frames, seed):
    b, d, sse = _sim_like(frames, seed)
    r = analyze_ptc(b, d, signal_se=sse)
    k = r.gain_dn_per_e
    assert k.available and abs(k.value - 0.28) <= 3 * k.se, k
    fw = r.full_well
    assert (fw.verdict == "ok" and abs(fw.value - 12000) <= 0.03 * 12000) or (fw.verdict == "not available" and fw.note)


# ------------------------------------------------------------ sanity as a verdict

def test_a_full_well_below_20_read_noises_is_not_ok():
    b, d, _ = make_levels(np.geomspace(2, 400, 20), K=0.5, fw_e=40, read_e=4, n_pixels=100_000, frames=4, seed=3)
    r = analyze_ptc(b, d)
    for e in (r.full_well, r.full_well_e["saturation_capacity"]):
        assert e.verdict != "ok", e
    sat = r.full_well_e["saturation_capacity"]
    assert "20x the read noise" in sat.note
    assert r.dynamic_range_db.verdict == "not available"


def test_sanity_turnoff_below_5_percent_and_se_above_value():
    from ares.analysis.stats.estimate import Estimate
    from ares.analysis.stats.physical import sane

    assert sane(Estimate(3.0, 4.0, "DN"), "x").verdict == "not available"
    e = sane(Estimate(30.0, 1.0, "DN"), "PTC turnoff", 100.0, "5 % of the brightest level's signal")
    assert e.verdict == "not available" and "5 % of the brightest" in e.note


def test_saturation_capacity_needs_its_level_and_k_within_3_percent_together():
    """Each within 3 % is not enough: a level located to 2.9 % and K to 1.4 % (2 SE 2.8 %)
    give 4 % together (quadrature); with K to 0.3 % the same level is "ok"."""
    from ares.analysis.ptc.sanity import _located_and_measured
    from ares.analysis.stats.estimate import Estimate

    sat = Estimate(40000.0, 300.0, "e-")
    e = _located_and_measured(sat, "saturation capacity", 0.029, Estimate(1.0, 0.014, "DN/e-"))
    assert e.verdict == "not available" and "2.9 %" in e.note and "together" in e.note
    assert _located_and_measured(sat, "saturation capacity", 0.029, Estimate(1.0, 0.003, "DN/e-")).verdict == "ok"
    assert _located_and_measured(sat, "saturation capacity", 0.0, Estimate(1.0, 0.014, "DN/e-")).verdict == "ok"


# --------------------------------------------------------- the headline by evidence

def _bf_table(path: Path, with_counts: bool):
    S = np.linspace(300, 60000, 43)
    g, a00 = 0.7, -2.5e-6  # K = 1/g = 1.43 DN/e-, brighter-fatter at LSST-CCD strength
    V = (np.expm1(2 * a00 * S * g) / (2 * a00 * g * g)) + 25
    V[S > 52000] = V[S <= 52000][-1] * np.linspace(0.9, 0.2, int((S > 52000).sum()))
    rng = np.random.default_rng(7)
    V = V * (1 + 0.004 * rng.standard_normal(S.size))
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["mean", "var"] + (["n_pixels", "n_frames"] if with_counts else []))
        w.writerows([[s, v] + ([250000, 2] if with_counts else []) for s, v in zip(S, V)])
    return 1 / g


def test_headline_gain_does_not_depend_on_a_guessed_pixel_count(capsys, tmp_path):
    k_true = _bf_table(tmp_path / "bf.csv", False)
    heads = []
    for px in (None, 100, 10_000, 10_000_000):
        d = _json(capsys, ["ptc", str(tmp_path / "bf.csv"), "--json"] + ([] if px is None else ["--pixels", str(px)]))
        heads.append((d["gain_headline"]["estimator"], d["gain_dn_per_e"]["value"], d["gain_dn_per_e"]["se"]))
    assert {h[0] for h in heads} == {"astier"}, heads
    for _, k, se in heads:
        assert abs(k - k_true) <= max(0.01 * k_true, 3 * se), heads


# --------------------------------------------------------- the corpus, a subset

SUBSET = stratified(240, 96)


@pytest.fixture(scope="module")
def subset(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("corpus")
    return [(case(i), *run_case(case(i), tmp)) for i in SUBSET]


def test_corpus_subset_rates_and_no_absurd_ok(subset):
    n = len(subset)
    gain = sum(j["gain"] for _, _, j in subset) / n
    turnoff = sum(j["turnoff"] for _, _, j in subset) / n
    absurd = [(c.i, j["absurd"]) for c, _, j in subset if j["absurd"]]
    # measured on this subset (see benchmarks/ptc_corpus.md for the full corpus and the
    # issue's targets, 99 % and 98 %, which these floors are below)
    assert gain >= 0.90, gain
    assert turnoff >= 0.70, turnoff
    assert not absurd, absurd


def _wrong_ok(subset, key, truth_key):
    return [(c.i, d[key]["value"], c.truth[truth_key]) for c, d, _ in subset if d[key]["verdict"] == "ok"
            and abs(d[key]["value"] - c.truth[truth_key]) > 0.03 * c.truth[truth_key]]


def test_corpus_subset_never_a_wrong_ok_turnoff_or_saturation_capacity(subset):
    """A turnoff the scatter cannot identify within 3 %, or a charge whose K is not known to
    1 %, is "not available" with the interval in the reason, never a wrong "ok" (issue 48;
    the full corpus: benchmarks/ptc_corpus.md, ~1 % of the "ok" turnoffs off)."""
    assert len(_wrong_ok(subset, "turnoff_dn", "turnoff_dn")) <= 1, _wrong_ok(subset, "turnoff_dn", "turnoff_dn")
    assert len(_wrong_ok(subset, "saturation_capacity_e", "sat_e")) <= 1
    unloc = [d["turnoff_dn"]["note"] for _, d, _ in subset if d["turnoff_dn"]["verdict"] == "not available"]
    assert unloc and all("DN" in u for u in unloc)
    assert any("not located within 3 %" in u for u in unloc), unloc[:3]
    ok = sum(d["turnoff_dn"]["verdict"] == "ok" for _, d, _ in subset)
    assert ok >= 0.6 * len(subset), ok  # honest, not silent: most turnoffs are still located


@pytest.mark.parametrize("i", [1, 7, 49])
def test_the_fall_beyond_the_turnoff_locates_it(tmp_path, i):
    """Roll-offs with 1.9-4.7 % per-level noise whose last level on the curve the window
    before the departure left to within 5-8 % ("not available"); the levels of the whole
    fall (``changepoint.fall_cost``) place it, as the oracle that knows the generating model
    does (benchmarks/ptc_corpus.md): "ok" and within 3 % of truth."""
    c = case(i)
    d, j = run_case(c, tmp_path)
    assert d["turnoff_dn"]["verdict"] == "ok" and j["turnoff"], (d["turnoff_dn"], c.truth["turnoff_dn"])


@pytest.mark.parametrize("i", [146, 453, 701])
def test_a_low_noise_sparse_curve_is_located(tmp_path, i):
    """Sparse curves (10-18 levels) with 0-0.3 % per-level noise whose window models left
    the level before the turnoff plausible (8-25 % away: "not available"); where the levels'
    measured scatter is <= 1 % the likelihood thresholds are tighter (``turnoff.LOW_NOISE``),
    and the turnoff is "ok" and within 3 % of truth."""
    c = case(i)
    d, j = run_case(c, tmp_path)
    assert d["turnoff_dn"]["verdict"] == "ok" and j["turnoff"], (d["turnoff_dn"], c.truth["turnoff_dn"])


@pytest.mark.parametrize("i", [532, 1882])
def test_a_second_hump_s_shallow_first_fall_is_no_wrong_ok(tmp_path, i):
    """Second humps at 4.9-6.5 % noise whose first fall is 10-30 % below the curve at each
    level but < 4 SE (never a departure alone), the curve then climbing near its extension:
    "ok" 5-14 % above the turnoff before. A run of levels jointly > 5 SE below the curve under
    them (``turnoff._run_starts``) makes the fall plausible: "not available", the interval
    reaching the true turnoff (within 3 %)."""
    import re

    c = case(i)
    d, _ = run_case(c, tmp_path)
    to = d["turnoff_dn"]
    assert to["verdict"] == "not available", to
    lo = float(re.search(r"only between (\S+) and", to["note"]).group(1))
    assert lo <= 1.03 * c.truth["turnoff_dn"], (lo, c.truth["turnoff_dn"])


def test_a_k_from_a_three_level_line_is_not_ok(tmp_path):
    """Corpus curve 701 (10 levels, exact, brighter-fatter): its turnoff is located exactly,
    but K comes from an unweighted line through 3 levels, 4.8 % low at a residual SE of
    1.3 %: with 1 degree of freedom that SE is itself a guess (Student's t: 3 SE become 236),
    so K is not "ok" (it was, 3.7 SE off), nor any charge on it. Curve 1976 (4 levels, 2
    dof): K 13.9 % low at a residual SE of 3.1 % stays "ok" with its SE x 6.4, and within it."""
    for i, n, ok in ((701, 3, False), (1976, 4, True)):
        c = case(i)
        d, j = run_case(c, tmp_path)
        k = d["gain_dn_per_e"]
        assert d["gain_model"]["levels"] == n and d["gain_headline"]["estimator"] == ("ols" if ok else None), i
        assert "Student's t" in k["note"], k
        assert (k["verdict"] == "ok") == ok and (j["gain"] or not ok), (i, k)
        assert d["saturation_capacity_e"]["verdict"] == "not available", (i, d["saturation_capacity_e"])
        if i == 701:
            assert d["turnoff_dn"]["verdict"] == "ok" and j["turnoff"]


def test_a_turnoff_located_tighter_at_low_scatter_keeps_its_charge_wide(tmp_path):
    """Where the levels scatter <= 7 % (4 % before session 5), the "before the one picked"
    rule keeps a level only within e^-3 of the fall model's best (its marginal cost,
    ``turnoff.BEFORE_LOW_NOISE``): corpus curve 78
    (104 levels, 3.4 % noise) has its turnoff located within 3 % ("ok"; it was "not
    available", between 17813 and 18688 DN); its saturation capacity is judged on the wider
    interval and stays "not available". Curve 1084 (the tightening alone made its saturation
    capacity a wrong "ok": level late by 1.4 %, K 1.8 % low) keeps it "not available"."""
    for i in (78, 1084):
        c = case(i)
        d, j = run_case(c, tmp_path)
        assert d["turnoff_dn"]["verdict"] == "ok" and j["turnoff"], (i, d["turnoff_dn"])
        assert d["saturation_capacity_e"]["verdict"] == "not available", (i, d["saturation_capacity_e"])


@pytest.mark.parametrize("i", [0, 249, 1110, 116, 432])
def test_the_fall_model_s_evidence_locates_a_level_its_profile_left(tmp_path, i):
    """Curves at 2.9-6.6 % noise (17-97 levels; clips, a dip, an upturn) whose turnoff the window picks
    right but whose level before it (3.3-5.4 % lower) the "before the one picked" rule kept:
    the fall model's profile lets the first level past a turn sit on the curve at no cost
    (the turn just before it, any rate), so it could not tell them apart ("not available").
    Its marginal cost -- the turn's place and the rate averaged over their priors
    (``changepoint.fall_cost``) -- does, where the levels scatter <= 7 %: "ok" and within 3 %
    of truth; the saturation capacity keeps the wider interval."""
    c = case(i)
    d, j = run_case(c, tmp_path)
    assert d["turnoff_dn"]["verdict"] == "ok" and j["turnoff"], (d["turnoff_dn"], c.truth["turnoff_dn"])


def test_t_quantile_closed_forms():
    """``fit.t_quantile`` against Student's t closed forms: 1 dof is Cauchy, tan(pi (p - 1/2));
    2 dof, (2p - 1) / sqrt(2 p (1 - p)); many dof, the normal's 3 SE."""
    from ares.analysis.ptc.fit import residual_se_widening, t_quantile

    for p in (0.9, 0.97725, 0.99865):
        assert t_quantile(p, 1) == pytest.approx(math.tan(math.pi * (p - 0.5)), rel=1e-10)
        assert t_quantile(p, 2) == pytest.approx((2 * p - 1) / math.sqrt(2 * p * (1 - p)), rel=1e-10)
    assert residual_se_widening(10**6) == pytest.approx(1.0, abs=1e-4)
    assert residual_se_widening(0) == math.inf


def test_corpus_subset_every_figure_has_a_verdict_and_a_reason(subset):
    for c, d, _ in subset:
        for key in ("gain_dn_per_e", "turnoff_dn", "full_well_e", "saturation_capacity_e"):
            e = d[key]
            assert e["verdict"] in ("ok", "not available", "lower limit", "upper limit"), (c.i, key)
            if e["verdict"] != "ok":
                assert e.get("note"), (c.i, key)
        assert d["decision_errors"]["note"], c.i


@pytest.mark.parametrize("i", [291, 1515])
def test_a_k_astier_cannot_measure_on_few_levels_comes_from_the_line(tmp_path, i):
    """12-14-level corpus curves (seed 0): the Astier fit's K, its residual SE carrying Student's t
    for 2-4 dof, is not measured (3 SE above K) where its curvature is not significant -- the
    line, one parameter fewer, states K within its error (it was "not available")."""
    c = case(i, 0)
    res, j = run_case(c, tmp_path)
    k = res["gain_dn_per_e"]
    assert k["verdict"] == "ok" and j["gain"] and "one parameter fewer" in k["note"], (k, j)


def test_a_line_its_residuals_do_not_follow_gives_no_k(tmp_path):
    """Corpus seed 3 curve 1140 (a clip at 9 % noise, 337 levels, no departure found): the unweighted
    line through the levels, plateau included, gave K 0.085 ± 0.010 DN/e- "ok" against 0.209 -- an
    absurd "ok". Its residuals run in long stretches of one sign (a runs test, no errors needed):
    K was "not available", saying so. Since a collapse that no departure confirmed ends the fit
    (``turnoff.ptc_turnoff_found``), the plateau is no longer fitted: K 0.2104 ± 0.0036, within
    1 % of the truth. White residuals are not flagged (false-alarm rate ~ RUNS_P)."""
    from ares.analysis.ptc.fit import RUNS_P, runs_p

    res, j = run_case(case(1140, 3), tmp_path)
    k = res["gain_dn_per_e"]
    assert not j["absurd"] and (j["gain"] if k["verdict"] == "ok" else "runs test" in k["note"]), k
    rng = np.random.default_rng(48)
    p = np.array([runs_p(rng.standard_normal(60)) for _ in range(2000)])
    assert np.mean(p < RUNS_P) <= 0.004 and runs_p(np.r_[np.ones(30), -np.ones(30)]) < 1e-9


@pytest.mark.parametrize("i, seed, tails", [(1180, 1, "t3"), (1180, 1, "gauss"), (760, 0, "gauss")])
def test_a_collapse_that_comes_back_ends_the_fit_and_locates_no_turnoff(tmp_path, i, seed, tails):
    """Second humps no departure was confirmed on (the variance fell below 70 % of its top, then
    climbed back): the curve was "not reached", K from a line through the hump -- 0.66 ± 0.21
    against 1.34, "ok" (t3 seed 1 curve 1180; the Gaussian one lost its gain). The fit now stops
    at the collapse and the turnoff is "not available": it may lie anywhere past the curve's
    first quarter (seed 0 curve 760: a hump rising on beyond it gave an "ok" 14 % high when the
    interval began at the collapse)."""
    c = case(i, seed, tails)
    d, j = run_case(c, tmp_path)
    assert j["gain"] and not j["absurd"], (d["gain_dn_per_e"], c.truth["K"])
    assert d["turnoff_dn"]["verdict"] == "not available", d["turnoff_dn"]


def _outlier_table(tmp_path, wild: float, seed: int = 0) -> tuple[dict, float]:
    """``ares ptc`` on a 60-level line (K 0.5, 2 % per-level noise, with counts whose errors
    match it, a clip beyond 40 000 DN) whose level at 30 % of the turnoff has ``wild`` x its
    variance; (result, true K)."""
    from ares.commands.ptc import analyse_table

    rng = np.random.default_rng(seed)
    S = np.linspace(400, 48000, 60)
    V = 0.5 * S * (1 + 0.02 * rng.standard_normal(S.size)) + 30.0
    V[S > 40000] = 0.01 * V[S > 40000]
    V[int(np.searchsorted(S, 12000))] *= wild
    npix = int(round(2.0 / (0.02**2 * 15)))
    path = tmp_path / f"wild_{seed}.csv"
    path.write_text("mean,var,n_pixels,n_frames\n" + "".join(f"{float(a)!r},{float(b)!r},{npix},16\n" for a, b in zip(S, V)))
    return analyse_table(path)[1], 0.5


def test_a_wild_fitted_row_is_dropped_with_its_reason_and_k_holds(tmp_path):
    """One fitted row with 4x its variance (a cosmic ray in a flat pair): the weighted fits'
    chi2 is that row's, the headline K moved by many SE "ok" before (corpus, Student-t noise,
    curve 1303: K 0.61 against 2.19, "ok"). It is dropped (cp_pipe's sigmaCutPtcOutliers
    rule on its neighbours' curve), its reason in the table, and K holds."""
    d, k = _outlier_table(tmp_path, 4.0)
    why = [s["reason"] for s in d["level_status"] if s["reason"].startswith("outlier row")]
    assert len(why) == 1, why
    g = d["gain_dn_per_e"]
    assert g["verdict"] == "ok" and abs(g["value"] - k) <= max(3 * g["se"], 0.01 * k), g
    c = case(1303, tails="t3")
    d, j = run_case(c, tmp_path)
    assert not j["absurd"] and j["gain"], (d["gain_dn_per_e"], c.truth["K"])


def test_no_gaussian_row_is_an_outlier():
    """The rule does not touch Gaussian scatter: 300 lines of 60 levels at 2 % noise, errors
    that match it -- no level dropped (a 5 SE draw: 6e-7 a level)."""
    from ares.analysis.ptc.headline import drop_outliers
    from ares.analysis.ptc.saturation import PtcLevel

    rng = np.random.default_rng(7)
    S = np.linspace(400, 28000, 60)
    for _ in range(300):
        V = 0.5 * S * (1 + 0.02 * rng.standard_normal(S.size))
        lv = [PtcLevel(i, float(s), float(v), 0.01 * s, 1e4, float(v), 0.0, 0.0, decision_se=0.01 * s)
              for i, (s, v) in enumerate(zip(S, V))]
        assert not drop_outliers(lv)[1]


def test_outliers_at_most_a_tenth_of_the_fitted_levels():
    """One wild row among 10 fitted levels is dropped (before, the cap undid the drop it had just
    allowed: one is a tenth of 10); three among 10 are more than a tenth: a shape, none dropped."""
    from ares.analysis.ptc.headline import drop_outliers
    from ares.analysis.ptc.saturation import PtcLevel

    S = np.linspace(400, 28000, 10)
    V = 0.5 * S * (1 + 0.02 * np.random.default_rng(3).standard_normal(S.size))

    def lv(v):
        return [PtcLevel(i, float(s), float(x), 0.01 * s, 1e4, float(x), 0.0, 0.0, decision_se=0.01 * s)
                for i, (s, x) in enumerate(zip(S, v))]

    one = V.copy()
    one[5] *= 2.0
    kept, dropped = drop_outliers(lv(one))
    assert [d.index for d in dropped] == [5] and len(kept) == 9
    three = one.copy()
    three[[2, 8]] *= 2.0
    assert not drop_outliers(lv(three))[1]
