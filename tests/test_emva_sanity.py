"""Impossible or empty EMVA figures are never "ok" (issue 48): negative dark currents under
every release, a dark current whose charge would saturate the pixel, figures whose SE is
larger than themselves, the General dark current from the variance (slope / (K R_d), not
/ R_d^2: off by eta), and a bright stack whose declared photons disagree with the set's own
characteristic curve (General PRNU from them would be off by as much). Truth: closed forms,
the simulator's set (tests/emva_sim.py) and a written PNG set (tests/emva_pngset.py)."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json

import pytest

from ares.analysis.emva.sanity import judge
from ares.analysis.stats.estimate import Estimate


def test_judge_closed_forms():
    sat = Estimate(10000.0, 50.0, "e-")
    v = judge({"mu_I_mean": Estimate(-581635.0, 1000.0, "e-/s"), "mu_I_var": Estimate(1.3e7, 1e6, "e-/s"),
               "u_I_mean": Estimate(3.0, 5.0, "e-/s"), "mu_p_min": Estimate(36.0, 490.0, "photons"),
               "DR": Estimate(595.0, 8044.0, ""), "K": Estimate(0.28, 0.001, "DN/e-")},
              saturation=sat, longest_exposure_s=0.5)
    assert v["mu_I_mean"].verdict == "not available" and "physical minimum" in v["mu_I_mean"].note
    assert v["mu_I_var"].verdict == "not available" and "saturation capacity" in v["mu_I_var"].note
    assert v["u_I_mean"].verdict == "upper limit" and v["u_I_mean"].value == 8.0
    for k in ("mu_p_min", "DR"):
        assert v[k].verdict == "not available" and "SE is larger than the value" in v[k].note, k
    assert v["K"].verdict == "ok" and v["K"].value == 0.28


def _emva(desc, release):
    from ares.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["emva", str(desc), "--release", release, "--json"]) == 0
    d = json.loads(buf.getvalue())
    return d.get("values", d)


@pytest.fixture(scope="module")
def falling_dark(tmp_path_factory):
    from emva_pngset import write_set

    return write_set(tmp_path_factory.mktemp("fall"), dark_slope_dn_per_s=-2000.0)


@pytest.mark.parametrize("release,key", [("3.0", "u_I_mean"), ("4.0-linear", "mu_I_mean"),
                                         ("4.0-general", "mu_I_mean")])  # (3.1 = 3.0's figures, re-judged)
def test_negative_dark_current_is_never_ok_under_any_release(falling_dark, release, key):
    v = _emva(falling_dark, release)
    assert v[key]["verdict"] != "ok", (release, v[key])


@pytest.fixture(scope="module")
def sim_set():
    from emva_sim import simulate

    from ares.analysis.emva.general import general_from_input
    from ares.analysis.emva.sheet import evaluate_linear

    inp, truth, s = simulate(4, L=16, dark_current_e_per_s=400.0)
    sh = evaluate_linear(inp)
    return inp, sh, general_from_input(inp, sh.photon_transfer), s


def test_general_dark_current_from_the_variance_agrees_with_the_mean(sim_set):
    """Both are the same dark current in photons/s: slope of the mean / R_d and slope of the
    variance / (K R_d). Dividing the variance's slope by R_d^2 gave 1/eta times the mean's
    (the General sheet's 6.61 against 4.08 photons/s, 8 SE apart)."""
    _, sh, gen, s = sim_set
    m, v = gen.values["mu_I_mean"], gen.values["mu_I_var"]
    assert m.verdict == "ok" and v.verdict == "ok", (m, v)
    assert abs(v.value - m.value) < 3 * (v.se ** 2 + m.se ** 2) ** 0.5, (m, v)
    eta = sh.values["QE"].value / 100
    lin = sh.values["mu_I_mean"]  # e-/s: photons/s = e-/s / eta
    assert abs(m.value - lin.value / eta) < 3 * m.se + 3 * lin.se / eta


def test_general_prnu_from_a_stack_with_inconsistent_photons(sim_set):
    from ares.analysis.emva.general import general_from_input

    inp, sh, gen, _ = sim_set
    assert gen.values["PRNU1288"].verdict == "ok"
    bad = dataclasses.replace(inp, stack_bright=dataclasses.replace(inp.stack_bright,
                                                                    photons=inp.stack_bright.photons / 12))
    g2 = general_from_input(bad, sh.photon_transfer)
    e = g2.values["PRNU1288"]
    assert e.verdict == "not available" and "inconsistent photon counts" in e.note and "12" in e.note, e
    assert all(g2.values[k].verdict == "not available" for k in ("PRNU1288_row", "PRNU1288_col", "PRNU1288_pix"))


def test_key_figures_snr_max_is_named_apart_from_the_datasheets():
    """Two SNR maxima, two names (issue 52, docs/quantities.md): the key figures' is sqrt of the
    photon transfer's saturation capacity, under its own name and definition; the datasheet's
    SNR_max (on the EMVA evaluation's own mu_e.sat, 95.866 against 95.881 on the 8-bit set) is
    not put under that name."""
    from types import SimpleNamespace

    import numpy as np

    from ares.analysis.ptc.levels import LevelStats
    from ares.analysis.ptc.photon_transfer import analyze_ptc
    from ares.report.tables import PtcGroup, compute_key_figures

    K, n = 0.25, 20
    q = np.r_[np.geomspace(100, 16000, n - 4), [16000 * 1.05, 16000 * 1.1, 16000 * 1.2, 16000 * 1.3]]
    s = K * np.minimum(q, 16000)
    v = K * K * np.minimum(q, 16000) + 4.0
    v[n - 4:] = 0.5
    res = analyze_ptc([LevelStats(100 + a, b, 100000, 16, 0.0) for a, b in zip(s, v)],
                      [LevelStats(100.0, 4.0, 100000, 16) for _ in s], photons=q / 0.6)
    g = PtcGroup(1.0, [], res, {}, list(q / 1e6), [None] * n, list(q / 0.6))
    em = Estimate(95.866, 0.2, "", "sqrt(mu_e.sat) (Eq. 55)").to_dict()
    run = SimpleNamespace(analyses={"emva4": {"values": {"SNR_max": em}}}, stages=[], complete=True)
    kf = compute_key_figures(run, [g])
    from ares import labels

    sat = kf["full_well_e.saturation_capacity"]["value"]
    assert kf["snr_max_emva"]["value"] == pytest.approx(np.sqrt(sat), rel=1e-12) != 95.866
    assert kf["snr_max_emva"]["label"] == labels.figure_name("snr_max_emva") and "sqrt" in kf["snr_max_emva"]["label"]
