"""EMVA 1288 Release 4.0 General: its whole Table 2 in ``ares emva --release 4.0-general
--json``, each entry a value with its SE or verdict, or not available with the reason
("cannot be measured" with the clause of the text for QE, K and 1/K), against computations
written here from the General text (Sections 6.6 - 6.8, 7.1, 8, Eqs. 44 - 59) on the
reference CCD, and on simulated sets: a linear one (mu_p.min where the steps reach SNR_p =
1) and one with a known nonlinearity (an ADC INL bow: Linear and General agree on mu_p.sat,
LE is replaced by the statement that the curve is nonlinear)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from ares.analysis.emva.general_table import GENERAL_TABLE2

sys.path.insert(0, str(Path(__file__).parent))
from emva_sim import simulate  # noqa: E402
from ptc_synth import make_levels  # noqa: E402

DESC = Path(__file__).resolve().parents[2] / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / \
    "EMVA1288_Data.txt"
on_ccd = pytest.mark.skipif(not DESC.is_file(), reason="the EMVA reference data set is not in ../shared/data/")


@pytest.fixture(scope="module")
def ccd():
    import contextlib
    import io

    from ares.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["emva", str(DESC), "--release", "4.0-general", "--json", "--pixel-size-um", "7.4"]) == 0
    return json.loads(buf.getvalue())


@on_ccd
def test_every_table2_entry_is_there_with_its_verdict(ccd):
    v = ccd["values"]
    keys = [k for k, _, _ in GENERAL_TABLE2]
    assert list(v)[: len(keys)] == keys  # the order of General Table 2
    for k, sym, unit in GENERAL_TABLE2:
        e = v[k]
        assert e["symbol"] == sym and e["unit"] == unit, k
        if e["verdict"] == "ok":
            assert e["value"] is not None and e["se"] is not None and e["se"] > 0, k
        elif e["verdict"] == "not available":
            assert e["value"] is None and e.get("note"), k
        else:
            assert e["verdict"] in ("upper limit", "lower limit") and e["value"] is not None, k
    for k in ("QE", "K", "K_inv"):  # General Table 2 and Section 6.7: not estimable with the general model
        assert v[k]["value"] is None and v[k]["note"].startswith("cannot be measured") and "Section 6.7" in v[k]["note"]
    for k in ("sigma_y_dark", "sigma_d", "SNR_max", "DSNU1288_row", "PRNU1288", "PRNU1288_pix", "LE", "mu_I_mean"):
        assert v[k]["verdict"] == "ok", k
    assert v["sigma_d"]["unit"] == "photons" and v["mu_I_mean"]["unit"] == "photons/s"
    assert v["mu_p_sat_area"]["value"] == pytest.approx(v["mu_p_sat"]["value"] / 7.4**2)


def _dark_and_curve():
    """From the text: the characteristic curve mu_y - mu_y.dark vs mu_p up to saturation by
    the cubic B-spline of Eqs. 44 - 47 (uniform knots d * (-3 .. P + 3), d = mu_p.sat / P,
    plain least squares over the measured points, no added point), R_d its slope at 0
    (Eq. 25); the dark variances of the steps (Eq. 18) and their exposure times."""
    from scipy.interpolate import BSpline

    from ares.hardware.emva_descriptor import iter_level, read_descriptor

    desc = read_descriptor(DESC)

    def pair(lv):
        a, b = (np.asarray(x, np.float64) for x in list(iter_level(desc, lv))[:2])
        return (a.mean() + b.mean()) / 2, np.mean((a - b) ** 2) / 2 - (a.mean() - b.mean()) ** 2 / 2, a, b

    tb = sorted(desc.temporal_bright, key=lambda lv: lv.photons)
    up = np.array([lv.photons for lv in tb])
    t = np.array([lv.exposure_s for lv in tb])
    br = [pair(lv) for lv in tb]
    dk = [pair(desc.dark_for(lv, "temporal")) for lv in tb]
    sig = np.array([b[0] - d[0] for b, d in zip(br, dk)])
    frac = np.array([(np.count_nonzero(b[2] == 4095) + np.count_nonzero(b[3] == 4095)) / (2 * b[2].size) for b in br])
    isat = int(np.flatnonzero(frac > 0.002)[0]) - 1
    P = 6  # "6 to 8 intervals" for ~50 steps (General Section 6.6); ARES takes 6 for these 37
    d = up[isat] / P
    knots = d * np.arange(-3, P + 4)
    A = BSpline.design_matrix(up[: isat + 1], knots, 3).toarray()
    coef = np.linalg.lstsq(A, sig[: isat + 1], rcond=None)[0]
    Rd = float(BSpline(knots, coef, 3).derivative()(0.0))
    return Rd, t, np.array([x[1] for x in dk]), np.array([x[0] for x in dk])


@on_ccd
def test_dark_noise_dark_current_and_dsnu_in_photons_from_the_text(ccd):
    """Method I (the exposure time varies): sigma_y.dark^2 is the offset of its regression over
    the exposure times (General Section 6.7), sigma_d = sqrt(sigma_y.dark^2 - 1/12) / R_d
    (Eq. 50); dark current = slopes of the dark mean / R_d and of the variance / (K R_d) (Eqs.
    22 - 25, Section 7.1); DSNU1288 parts = s_y.dark / R_d (Eq. 58) with the split of the Linear text."""
    from test_emva4_as_written import _split

    from ares.hardware.emva_descriptor import iter_level, read_descriptor

    v = ccd["values"]
    Rd, t, s2d, mud = _dark_and_curve()
    assert v["R_d"]["value"] == pytest.approx(Rd, rel=1e-6)
    b, a = np.polyfit(t, s2d, 1)
    assert v["sigma_y_dark"]["value"] == pytest.approx(math.sqrt(a), rel=1e-6)
    assert v["sigma_d"]["value"] == pytest.approx(math.sqrt(a - 1 / 12) / Rd, rel=1e-6)
    # from the variance the photons need K too (the variance grows by K^2 per electron, R_d = K eta):
    # slope / (K R_d), K of the 4.0 Linear evaluation (1.5 % below the published Release 3 0.280769);
    # slope / R_d^2 divided by eta^2 where eta belongs (issue 48)
    assert v["mu_I_var"]["value"] == pytest.approx(b / (0.280769 * Rd), rel=0.02)
    assert "K from the Linear evaluation" in v["mu_I_var"]["note"]
    assert v["mu_I_mean"]["value"] == pytest.approx(np.polyfit(t, mud, 1)[0] / Rd, rel=1e-6)
    desc = read_descriptor(DESC)
    lv = desc.spatial_bright[0]
    dark = _split(np.array([np.asarray(f, np.float64) for f in iter_level(desc, desc.dark_for(lv, "spatial"))]))
    e = v["DSNU1288_row"]
    assert e["value"] == pytest.approx(math.sqrt(dark["row"]) / Rd, abs=0.3 * e["se"])


@on_ccd
def test_threshold_only_where_a_step_reaches_it(ccd):
    """Every step of the reference CCD has SNR_p > 1: mu_p.min is only "below the lowest step"
    (an upper limit at its photons), and DR = mu_p.sat / mu_p.min a lower limit; ARES's
    extrapolation is in a note, labelled as beyond the text."""
    v = ccd["values"]
    assert v["mu_p_min"]["verdict"] == "upper limit" and "below the lowest step" in v["mu_p_min"]["note"]
    assert v["mu_p_min"]["value"] == pytest.approx(120.0)  # the lowest step's photons
    assert v["DR"]["verdict"] == "lower limit"
    assert any("beyond the text" in n for n in ccd["notes"])


def _levels_down_to_snr_1():
    """A linear sensor (K 0.5 DN/e-, eta 0.6, read noise 4 e-) whose steps start well below
    the threshold (~12 photons), method II (one exposure time)."""
    mu_e = np.r_[np.geomspace(0.5, 200, 24), np.linspace(300, 19000, 40), 19800, 20000, 20400, 21000]
    b, d, tr = make_levels(mu_e, K=0.5, fw_e=20000.0, read_e=4.0, adc_limited=True, seed=5)
    return b, d, mu_e / 0.6


def test_threshold_where_the_steps_reach_snr_1():
    """With steps through SNR_p = 1 the regression of Section 6.8 gives mu_p.min, a value
    with its SE; for this linear sensor it is the Linear Eq. 26 threshold,
    (sqrt(sigma_y.dark^2/K^2 + 1/4) + 1/2) / eta, within a few percent (the spline's bias)."""
    from ares.analysis.emva.general import emva_general

    b, d, up = _levels_down_to_snr_1()
    g = emva_general(b, d, up)
    e = g.values["mu_p_min"]
    assert e.available and not e.bound and e.se > 0
    truth = (math.sqrt((0.25 * 16 + 1 / 12) / 0.25 + 0.25) + 0.5) / 0.6
    assert e.value == pytest.approx(truth, rel=0.05)
    assert g.values["K"].note.startswith("cannot be measured")
    assert g.values["DSNU1288"].note.startswith("no dark stack")


@pytest.fixture(scope="module")
def nonlinear():
    from ares.analysis.emva.sheet import evaluate_linear
    from ares.analysis.emva.general import general_from_input

    inp, tr, s = simulate(3, adc_inl_lsb=150.0)
    sh = evaluate_linear(inp)
    return inp, sh, general_from_input(inp, sh.photon_transfer)


def test_nonlinear_set_linear_and_general_agree_on_saturation(nonlinear):
    """A 150-LSB INL bow: Eq. 51 as written fails; both releases take mu_p.sat as the photons
    at the saturation step, so they agree exactly on it (before, Linear's y_sat/R differed
    by 1.6 %)."""
    inp, sh, g = nonlinear
    pt = sh.photon_transfer
    assert pt.linear is False and pt.linear_check.mean_rel_dev >= 0.03
    up = np.sort(inp.photons)
    assert sh.values["mu_p_sat"].value == g.values["mu_p_sat"].value == up[pt.index_sat]
    assert sh.values["mu_e_sat"].value == pytest.approx(sh.values["QE"].value / 100 * up[pt.index_sat], rel=1e-12)


def test_nonlinear_set_general_table(nonlinear):
    """LE is not given as a number for a nonlinear curve (General Table 2 asks for the type of
    nonlinearity); PRNU1288 in photons (Eq. 59) is close to the sensor's PRNU (1 %, this
    sensor's default) as the slope at mu_p.50 undoes the bow; DSNU/PRNU parts all present."""
    inp, sh, g = nonlinear
    v = g.values
    assert not v["LE"].available and v["LE"].note.startswith("nonlinear characteristic curve")
    for k, _, _ in GENERAL_TABLE2:
        assert k in v
    assert v["PRNU1288"].available and v["DSNU1288_col"].unit == "photons"
    # Eq. 59 by hand from the splits and the curve's slopes
    ds, bs = inp.stack_dark.split("4.0"), inp.stack_bright.split("4.0")
    slope = float(g.curve.slope(inp.stack_bright.photons))
    rd = v["R_d"].value
    by_hand = 100 * math.sqrt(bs.total / slope**2 - ds.total / rd**2) / inp.stack_bright.photons
    assert v["PRNU1288"].value == pytest.approx(by_hand, rel=1e-9)


def test_total_snr_eq_60(nonlinear):
    """Eq. 60 per step from its parts: mu_p / sqrt(sigma_p^2 + s_p^2), both variances carried to
    the input by the local slope (Eq. 56); below the temporal SNR_p wherever there is a
    spatial variance, and equal to it with none."""
    inp, sh, g = nonlinear
    order = np.argsort(inp.photons, kind="stable")
    s2 = np.array([inp.step_split[i][0].total for i in order])
    j = g.index_sat // 2
    slope = float(g.curve.slope(g.photons[j]))
    by_hand = g.photons[j] / math.sqrt(g.sigma_y[j] ** 2 / slope**2 + s2[j] / slope**2)
    assert g.snr_p_total[j] == pytest.approx(by_hand, rel=1e-9)
    ok = np.isfinite(g.snr_p_total) & np.isfinite(g.snr_p)
    assert np.all(g.snr_p_total[ok] <= g.snr_p[ok] * (1 + 1e-12))
    from ares.analysis.emva.general_table import total_snr

    assert np.allclose(total_snr(g, np.zeros_like(s2))[ok], g.snr_p[ok], rtol=1e-9)
