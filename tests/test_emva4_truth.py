"""EMVA 1288 Release 4.0 on the simulated sensor (truth known): every Table 2 figure the
simulator has a truth for, over 20 seeds, is recovered within its reported SE (the
row/column/pixel patterns by ARES's option rowcol_corrected, which undoes the high-pass's
bias on them) (the z-scores'
mean is ~0 and their spread ~1); the Linear evaluation flags a nonlinear sensor (Eq. 51)
and the General evaluation recovers its true characteristic curve."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from ares.analysis.emva.sheet import evaluate_linear
from ares.analysis.emva.general import emva_general
from ares.analysis.spatial.nonuniformity import nonuniformity_rowcol_corrected, split
from emva_sim import simulate

SEEDS = range(20)


def _truth(tr: dict, sheet) -> dict:
    G, r = tr["G"], tr["realized"]
    x = np.sort(np.asarray(sheet.curves["photons"]))
    out = {"K": G, "QE": 60.0, "sigma_d": math.sqrt(tr["Pt"] + tr["Rt"] + tr["Ct"]) / G,
           "DSNU1288_col": math.sqrt(r["Cs"]) / G, "DSNU1288_row": math.sqrt(r["Rs"]) / G,
           "DSNU1288_pix": math.sqrt(r["Ps"]) / G, "PRNU1288_col": 100 * math.sqrt(r["Cg"]),
           "PRNU1288_row": 100 * math.sqrt(r["Rg"]), "PRNU1288_pix": 100 * math.sqrt(r["Pg"]),
           "mu_I_mean": tr["dark_current_e_per_s"], "mu_I_var": tr["dark_current_e_per_s"]}
    if sheet.photon_transfer.index_sat is not None and not sheet.values["mu_e_sat"].bound:
        out["mu_e_sat"] = 0.6 * x[sheet.photon_transfer.index_sat]  # eta * mu_p at the saturation step
    return out


@pytest.fixture(scope="module")
def zscores():
    z: dict[str, list[float]] = {}
    les, checks, rel = [], [], {}
    for seed in SEEDS:
        inp, tr, s = simulate(seed)
        sh = evaluate_linear(inp)
        pt = sh.photon_transfer
        checks.append((pt.linear_check.mean_rel_dev, pt.linear, pt.linear_noise_floor.holds))
        K = sh.values["K"]
        ext = nonuniformity_rowcol_corrected(inp.stack_dark.split("4.0"), inp.stack_bright.split("4.0"), K.value,
                                             K.se)
        own = _pattern_truth(inp, tr, s)
        for k, t in _truth(tr, sh).items():
            # the sensor's own row/column/pixel patterns: what option rowcol_corrected estimates (the text's
            # Eqs. 39 - 41 read the high-passed patterns: test_emva4_as_written.py); its SE is the measurement
            # error of THIS sensor's pattern (spatial.pattern_se), so z is taken against the option's split of
            # the sensor's expected images, and the realized patterns' variances (before the high-pass) are
            # the seeds' mean's truth (``rel``: the option undoes the filter's bias over sensors)
            e = ext[f"{k}.rowcol_corrected"] if k.startswith(("DSNU", "PRNU")) else sh.values[k]
            assert e.available and not e.bound, (seed, k, e)
            z.setdefault(k, []).append((e.value - own.get(k, t)) / e.se)
            if k in own:
                rel.setdefault(k, []).append(e.value / t - 1)
        les.append(sh.values["LE"])
    return {k: np.array(v) for k, v in z.items()}, les, checks, {k: np.array(v) for k, v in rel.items()}


def _pattern_truth(inp, tr: dict, sensor) -> dict:
    """DSNU1288/PRNU1288 parts of this sensor's own patterns as option rowcol_corrected reads
    them: its split (``Split.extended``) of the sensor's expected dark and bright stack
    images (``ares.sim.expected``: no temporal noise), DSNU in e- by the true gain."""
    from ares.sim.expected import expected_codes
    from emva_sim import FLUX, GAIN

    t50 = inp.stack_dark.exposure_s
    d = split(expected_codes(sensor, photon_flux=0.0, exposure_s=t50, analog_gain=GAIN), 0.0, 1).extended
    b = split(expected_codes(sensor, photon_flux=FLUX, exposure_s=t50, analog_gain=GAIN), 0.0, 1).extended
    out = {}
    for part in ("col", "row", "pix"):
        out["DSNU1288_" + part] = math.sqrt(max(d.get(part)[0], 0.0)) / tr["G"]
        out["PRNU1288_" + part] = 100 * math.sqrt(max(b.get(part)[0] - d.get(part)[0], 0.0)) / (b.mean - d.mean)
    return out


def test_eq51_on_a_linear_sensor(zscores):
    """The sensor is linear: the text's Eq. 51 deviation (local slopes of the General
    B-spline, P equal intervals up to saturation) is only the noise of the local slopes of
    this small (120 x 160) sensor's variances, ~1 - 3 %: it stays below 3 % on most seeds
    and near it on all; ARES's noise-floor variant (option eq51_noise_floor) accepts the
    linear model on every seed."""
    checks = zscores[2]
    devs = np.array([c[0] for c in checks])
    assert all(c[1] == (c[0] < 0.03) for c in checks)  # the verdict is the 3 % rule of Eq. 51
    assert np.median(devs) < 0.02 and devs.max() < 0.045, devs
    assert sum(c[1] for c in checks) >= 0.8 * len(checks), devs
    assert all(c[2] for c in checks)


@pytest.mark.parametrize("name", ["K", "QE", "sigma_d", "DSNU1288_col", "DSNU1288_row", "DSNU1288_pix",
                                  "PRNU1288_col", "PRNU1288_row", "PRNU1288_pix", "mu_I_mean", "mu_I_var",
                                  "mu_e_sat"])
def test_recovered_within_the_reported_se(zscores, name):
    z = zscores[0][name]
    assert z.size >= 15, f"{name}: only {z.size} of 20 seeds gave a value"
    # unbiased: the mean z over the seeds within 3 standard errors of 0 ...
    assert abs(z.mean()) < 3 / math.sqrt(z.size) + 0.25, (name, z.mean())
    # ... and the SE is honest: no seed beyond 4 SE, the spread not above 1.5
    assert np.abs(z).max() < 4, (name, z)
    assert z.std(ddof=1) < 1.5, (name, z.std(ddof=1))
    if name in zscores[3]:  # the option recovers the realized (unfiltered) patterns on average over sensors
        d = zscores[3][name]
        assert abs(d.mean()) < 3 * d.std(ddof=1) / math.sqrt(d.size) + 0.02, (name, d.mean(), d.std(ddof=1))


def test_linearity_error_of_a_linear_sensor_is_at_its_noise_floor(zscores):
    les = zscores[1]
    assert all(e.available for e in les)
    assert max(e.value for e in les) < 0.1  # % (the sensor is linear; LE is mean |noise|)


def test_highpass_removes_illumination_gradient_and_vignetting():
    """The same sensor under a flat field and under a 20 % left-right gradient times a
    cos^4-like vignetting: PRNU1288 differs by less than 1 % of its value (against the PRNU
    the nonuniform signal itself implies: the local PRNU scales with the local signal)."""
    rows, cols = 120, 160
    y, x = np.mgrid[:rows, :cols]
    r2 = ((x - cols / 2) ** 2 + (y - rows / 2) ** 2) / (cols / 2) ** 2
    shade = (1 + 0.2 * (x / cols - 0.5)) * (1 - 0.15 * r2)
    flat = evaluate_linear(simulate(7)[0]).values
    graded = evaluate_linear(simulate(7, flux_map=1e6 * shade / shade.mean())[0]).values
    # rms of the signal over the pixels the high-pass keeps (9-pixel border dropped), over
    # the mean signal of the whole image (the denominator of Eq. 67)
    implied = math.sqrt(float(np.mean((shade[9:-9, 9:-9] / shade.mean()) ** 2)))
    assert graded["PRNU1288"].value == pytest.approx(flat["PRNU1288"].value * implied, rel=0.01)
    assert graded["PRNU1288_pix"].value == pytest.approx(flat["PRNU1288_pix"].value * implied, rel=0.01)


def test_nonlinear_sensor_flagged_by_linear_and_recovered_by_general():
    """A 150-LSB INL bow (3.6 % of full scale): the Linear evaluation reports that its model
    does not hold (Eq. 51); the General B-spline follows the true characteristic curve --
    the expected ADC code sum_k Phi((x - T_k)/sigma) at the analog signal -- within 3 SE,
    while a straight line misses it by ~140 DN."""
    inp, tr, s = simulate(3, adc_inl_lsb=150.0)
    sh = evaluate_linear(inp)
    assert sh.photon_transfer.linear is False
    assert any("general model" in n for n in sh.notes)
    g = emva_general(inp.bright, inp.dark, inp.photons)
    top = g.index_sat
    up = g.photons[: top + 1]
    T = s.patterns.adc.thresholds
    order = np.argsort(inp.photons)
    sig = np.sqrt([inp.bright[i].var for i in order[: top + 1]])

    def ecode(x, sd):
        return float(norm.cdf((x - T) / sd).sum())

    x0 = tr["o"]
    true = np.array([ecode(x0 + tr["G"] * 0.6 * p, sd) for p, sd in zip(up, sig)]) - \
        ecode(x0, math.sqrt(inp.dark[0].var))
    fit = g.curve(up)
    se = g.curve.se(up)
    assert np.max(np.abs(fit - true) / np.maximum(se, 0.05)) < 4
    assert np.max(np.abs(true - tr["G"] * 0.6 * up)) > 100  # the curve is far from a line
    assert g.values["mu_p_min"].available and g.values["SNR_max"].available


def test_dark_current_at_several_temperatures():
    """Section 7.2: one dark-current series per temperature gives the dark current vs
    temperature data of the datasheet (no doubling temperature: Release 4.0 dropped it)."""
    import dataclasses

    inp, tr, _ = simulate(11)
    t = np.linspace(0.2, 1.2, 6)
    K = tr["G"]
    rates = {20.0: 2.0, 30.0: 4.0, 40.0: 8.0, 50.0: 16.0}  # e-/s
    temps = [(T, t, 64 + K * r * t, 1.5 + K * K * r * t) for T, r in rates.items()]
    sh = evaluate_linear(dataclasses.replace(inp, temperatures=temps))
    got = dict(sh.curves["dark_vs_temperature"])
    for T, r in rates.items():
        assert got[T].value == pytest.approx(r, rel=0.01)
