"""Issue 48's studies of photon transfer (``@pytest.mark.study``: ``make bench-quick``, not
``make test``); their measured tables are in ``benchmarks/ptc_corpus.md``.

- the full generated corpus (``tests/ptc_corpus.py``, 2000 curves with known truth): the
  rates it reaches, zero absurd values "ok";
- the shipped simulator's main job at 2, 4, 8, 16 and 64 frames x 10 seeds: K within 3 SE
  of the sensor's PTC truth (``test_scan_truth._ptc_k``; nominal 0.28 DN/e-) and the full
  well within 3 % of its truth (~12 000 e-) or "not available" with reason.

The issue's corpus targets (gain 99 %, turnoff and full well 98 %) are stated beside the
floors asserted here: the floors are what the analysis measurably reaches (a regression
guard), the gap is reported in ``benchmarks/ptc_corpus.md``, not hidden. The corpus runs
twice: the seed the analysis was developed on and a held-out one."""

from __future__ import annotations

from pathlib import Path

import pytest

from ptc_corpus import case, run_case

pytestmark = pytest.mark.study
N_CORPUS = 2000
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module", params=[0, 1], ids=["seed0", "heldout1"])
def corpus(request, tmp_path_factory):
    """The corpus the analysis was developed on (seed 0) and a held-out one (seed 1)."""
    tmp = tmp_path_factory.mktemp("corpus")
    return [(c, *run_case(c, tmp)) for c in (case(i, request.param) for i in range(N_CORPUS))]


def _wrong_ok(corpus, key, truth_key):
    ok = [(c, d) for c, d, _ in corpus if d[key]["verdict"] == "ok"]
    wrong = [(c.i, d[key]["value"], c.truth[truth_key]) for c, d in ok
             if abs(d[key]["value"] - c.truth[truth_key]) > 0.03 * c.truth[truth_key]]
    return len(ok), wrong


def test_full_corpus(corpus):
    n = len(corpus)
    gain = sum(j["gain"] for _, _, j in corpus) / n
    turnoff = sum(j["turnoff"] for _, _, j in corpus) / n
    absurd = [(c.i, j["absurd"]) for c, _, j in corpus if j["absurd"]]
    assert not absurd, absurd[:10]
    assert gain >= 0.98, gain  # target 0.99
    # target 0.98; measured 85.8 % (seed 0) and 86.0 % (held out): the rest is "not
    # available" with the interval, the noisy curves; an oracle that knows the generating
    # model but the turnoff reaches 99.5 %, 96.8-97.7 % at 5-10 % noise (benchmarks/ptc_corpus.md)
    assert turnoff >= 0.80, turnoff


def test_full_corpus_never_a_wrong_ok(corpus):
    """Measured: 13 of 1764 "ok" turnoffs off by > 3 % (seed 0; 17 of 1772 held out), 8 of
    ~1240 saturation capacities (8 of ~1234) -- ~1 %, was 142 of 1994 and 322 of 1994."""
    for key, truth_key in (("turnoff_dn", "turnoff_dn"), ("saturation_capacity_e", "sat_e")):
        n_ok, wrong = _wrong_ok(corpus, key, truth_key)
        assert len(wrong) <= 0.02 * n_ok, (key, n_ok, wrong[:10])


def test_full_corpus_exact_and_low_noise_curves_meet_the_targets(corpus):
    low = [(c, j) for c, _, j in corpus if c.params["noise"] <= 0.01]
    n = len(low)
    assert sum(j["gain"] for _, j in low) / n >= 0.98
    assert sum(j["turnoff"] for _, j in low) / n >= 0.95  # measured 99.3 % (seed 0), 99.0 % (held out)


@pytest.mark.parametrize("seed", [0, 1])
def test_heavy_tailed_corpus(tmp_path, seed):
    """The same curves with Student's t (3 dof) per-level noise, a family the rules were not
    developed on (benchmarks/ptc_corpus.md, "Heavy-tailed scatter"): measured 2 and 1 absurd "ok"
    (13 and 9 before stop 61), 17 / 16 wrong "ok" turnoffs of ~1700 (33 / 27)."""
    rows = [(c, *run_case(c, tmp_path)) for c in (case(i, seed, tails="t3") for i in range(N_CORPUS))]
    absurd = [(c.i, j["absurd"]) for c, _, j in rows if j["absurd"]]
    assert len(absurd) <= 3, absurd
    for key, truth_key in (("turnoff_dn", "turnoff_dn"), ("saturation_capacity_e", "sat_e")):
        n_ok, wrong = _wrong_ok(rows, key, truth_key)
        assert len(wrong) <= 0.02 * n_ok, (key, n_ok, wrong[:10])


# Frame counts where the nominal G = 0.28 DN/e- is what the PTC measures within its SE. The
# simulator's gain map has mean exactly G (ares/sim/patterns.py), but the sensor's physics
# moves the PTC slope by -0.05 % on every seed (gain spread +0.010 %, lag 1e-4 -0.02 %, the
# 0.5 LSB INL bow at the dark level -0.038 %; no seed-to-seed part left): 0.3-0.8 SE of K at
# 2-8 frames, 1.2 SE at 16 (seed 4: 3.9 SE from 0.28, 2.1 from the truth), 2.5 SE at 64 --
# there only the sensor's PTC truth (_ptc_k) is the truth (benchmarks/ptc_sim.md).
NOMINAL_K, NOMINAL_FRAMES = 0.28, (2, 4, 8)


@pytest.mark.parametrize("frames", [2, 4, 8, 16, 64])
def test_simulator_main_job(tmp_path_factory, frames):
    """Issue 48's main job, 10 seeds: K within 3 SE of what a PTC of the simulated sensor
    measures (``test_scan_truth._ptc_k``: the realized gain map's spread, the stack's lag,
    the ADC's INL bow) and, where that is 0.28 within the SE (``NOMINAL_FRAMES``), of the
    nominal 0.28 too; the full well within 3 % of its truth (``_full_well_e``) or not
    available with the reason. Every seed is judged before the assert (``-s`` prints them)."""
    from test_scan_truth import _full_well_e, _ptc_k, _run, _truth

    bad = []
    for seed in range(1, 11):
        scan, bench, res, stages = _run("photon_transfer", tmp_path_factory, frames=frames, seed=seed)
        ptc = res["ptc"]
        mid = next(s for s in stages if s["name"] == res["decomposition"]["stage"])
        t = _truth(scan, bench, mid["settings"])
        k_true = _ptc_k(t, mid["views"]["full"]["level"]["n_frames"])
        k, fw = ptc["gain_dn_per_e"], ptc["full_well_e"]
        k_ok = k["verdict"] == "ok" and bool(k.get("se"))
        ok = {"K ok": k_ok, "K vs PTC truth": k_ok and abs(k["value"] - k_true) <= 3 * k["se"]}
        if frames in NOMINAL_FRAMES:
            ok["K vs 0.28"] = k_ok and abs(k["value"] - NOMINAL_K) <= 3 * k["se"]
        if fw["verdict"] == "ok":
            fw_true = _full_well_e(t, k_true)
            ok["full well"] = abs(fw["value"] - fw_true) <= 0.03 * fw_true
            ok["full well vs 12 000 e-"] = abs(fw["value"] - t["full_well_e"]) <= 0.03 * t["full_well_e"]
        else:
            ok["full well n/a with reason"] = fw["verdict"] == "not available" and bool(fw.get("note"))
        z = {n: (k["value"] - v) / k["se"] if k.get("se") else float("nan") for n, v in (("t", k_true), ("n", NOMINAL_K))}
        print(f"frames {frames} seed {seed}: K {k['value']} +- {k.get('se')} {k['verdict']}, PTC truth {k_true:.5f} "
              f"({z['t']:+.1f} SE), 0.28 ({z['n']:+.1f} SE); full well {fw['value']} +- {fw.get('se')} {fw['verdict']}; "
              f"failed: {[n for n, v in ok.items() if not v]}")
        if not all(ok.values()):
            bad.append((seed, [n for n, v in ok.items() if not v], k, k_true, fw))
    assert not bad, (frames, bad)
