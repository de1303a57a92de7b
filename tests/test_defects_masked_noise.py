"""Issue 6: defects must not bias the noise components.

On the simulator with 1 % defective pixels (hot, warm, dead, stuck, noisy, RTS), the
13-component decomposition of the *masked* stacks (``MaskedStackAccumulator``: the
unbalanced Henderson-I ANOVA of ``ares.analysis.noise.masked``) stays within 3 standard errors
of the defect-free truth -- with the simulator's truth mask and with the mask the defects
module classifies -- while the plain (unmasked) decomposition is visibly biased.

Truth: fixed-pattern components (o, Cs, Rs, Ps; Pg, Cg, Rg) are the values realized by
this sensor instance, ``truth["realized"]`` (defect pixels are not part of them); temporal
ones (Ct, Rt, frame_global, G) are the model parameters; Pt is the realized clean Pt plus
the 1/12 DN^2 quantization the ADC adds (MS_E holds it; SCIENCE.md). The "clean twin"
column is the unmasked decomposition of the same seed rendered with
``SensorParams.without_defects()`` (same patterns, same noise draws).

Operating point as tests/test_defects_sim.py (5 C, 20 s: hot 8.5-25 e-/s, warm 1.3-3.8
e-/s, flat ~50 % of full well), crosstalk off so the flat truth is the plain gain maps.
"""

import math

import numpy as np
import pytest

sim = pytest.importorskip("ares.sim")

from ares.analysis import MaskedStackAccumulator, StackAccumulator, decompose_dark, decompose_flat  # noqa: E402
from ares.analysis.noise.decompose import StackAnalysis  # noqa: E402
from ares.analysis.defects import classify_stack  # noqa: E402

OP = dict(exposure_s=20.0, temperature_c=5.0)
FLUX = 500.0
RATES = dict(hot_rate_ppm=2000, warm_rate_ppm=2000, rts_rate_ppm=1500, dead_rate_ppm=1500,
             stuck_rate_ppm=1000, noisy_rate_ppm=2000)  # 1 % of the pixels in all
CLASSES = ("hot", "warm", "dead", "stuck", "noisy", "rts")
DARK_KEYS = ("o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global")
FLAT_KEYS = ("G", "Pg", "Cg", "Rg")
# components a per-pixel defect population must visibly bias when left in
BIASED = ("o", "Cs", "Rs", "Ps", "Pt", "Pg")


def _params(rows, cols):
    return sim.SensorParams(rows=rows, cols=cols, crosstalk_pct=0.0, rts_amplitude_e=30.0, **RATES)


def _acc(x, mask=None):
    a = StackAccumulator(x.shape[1:]) if mask is None else MaskedStackAccumulator(x.shape[1:], mask)
    for f in x:  # streamed frame by frame
        a.add(f)
    return a


def _truth_mask(tr, shape):
    m = np.zeros(shape, bool)
    for c in CLASSES:
        m[tr["defects"][c]] = True
    return m


def _truth(tr_dark, tr_flat):
    r, rf = tr_dark["realized"], tr_flat["realized"]
    t = {k: r[k] for k in ("o", "Cs", "Rs", "Ps", "Ct", "Rt", "frame_global")}
    t["Pt"] = r["Pt"] + tr_dark["quantization_dn2"]
    t.update({k: rf[k] for k in FLAT_KEYS})
    return t


def _decompose(dark, flat, mask=None, illumination="none"):
    da, fa = _acc(dark, mask), _acc(flat, mask)
    out = dict(decompose_dark(da))
    out.update(decompose_flat(fa, da, illumination=illumination))
    return out


@pytest.fixture(scope="module")
def run():
    p = _params(160, 200)
    s = sim.SimSensor(p, 1)
    dark = s.render(40, dark=True, **OP)
    flat = s.render(20, photon_flux=FLUX, **OP)
    trd, trf = s.truth(dark=True, **OP), s.truth(photon_flux=FLUX, **OP)
    twin = sim.SimSensor(p.without_defects(), 1)
    cdark = twin.render(40, dark=True, **OP)
    cflat = twin.render(20, photon_flux=FLUX, **OP)
    res = classify_stack(dark, flat, gain_dn_per_e=p.gain_dn_per_e(), exposure_s=OP["exposure_s"])
    tmask = _truth_mask(trd, dark.shape[1:])
    return dict(dark=dark, flat=flat, truth=_truth(trd, trf), tmask=tmask, cmask=res.defective(),
                cdark=cdark, cflat=cflat)


@pytest.mark.parametrize("illumination", ["none", "surface", "highpass"])
def test_masked_decomposition_matches_defect_free_truth(run, report, illumination):
    dark, flat, truth = run["dark"], run["flat"], run["truth"]
    tmask, cmask = run["tmask"], run["cmask"]
    assert 0.009 <= tmask.mean() <= 0.011
    m = _decompose(dark, flat, tmask, illumination)
    c = _decompose(dark, flat, cmask, illumination)
    u = _decompose(dark, flat, None, illumination)
    clean = _decompose(run["cdark"], run["cflat"], None, illumination)
    report.append(f"\n[issue 6] 160x200, 40 dark + 20 flat frames, illumination={illumination}: "
                  f"{int(tmask.sum())} defective pixels (truth), {int(cmask.sum())} classified, "
                  f"{int((tmask & cmask).sum())} in common")
    report.append(f"  {'comp':13s} {'truth':>11s} {'masked(truth)':>14s} {'masked(class.)':>15s} "
                  f"{'clean twin':>11s} {'UNMASKED':>11s} {'SE':>9s} {'z mask':>7s} {'z cls':>6s} {'z unm':>8s}")
    keys = DARK_KEYS + FLAT_KEYS
    fails = []
    for k in keys:
        t, se = truth[k], m[k].se
        zm, zc, zu = ((e[k].value - t) / se for e in (m, c, u))
        report.append(f"  {k:13s} {t:11.5g} {m[k].value:14.5g} {c[k].value:15.5g} {clean[k].value:11.5g} "
                      f"{u[k].value:11.5g} {se:9.3g} {zm:+7.2f} {zc:+6.2f} {zu:+8.1f}")
        if not (abs(zm) < 3 and abs(zc) < 3):
            fails.append(k)
        if k in BIASED and not abs(zu) > 3:
            fails.append(f"{k} (unmasked not biased)")
    assert not fails, "\n".join(report)


def test_monte_carlo_mean_of_masked_estimates(report):
    """40 small sensors (48x64, 1 % defects, truth mask): mean error within 3 SEM of 0."""
    n, F, Ff = 40, 16, 8
    keys = DARK_KEYS + FLAT_KEYS
    err = {k: [] for k in keys}
    err_u = {k: [] for k in keys}
    ses = {k: [] for k in keys}
    p = _params(48, 64)
    for seed in range(n):
        s = sim.SimSensor(p, 2000 + seed)
        dark = s.render(F, dark=True, **OP)
        flat = s.render(Ff, photon_flux=FLUX, **OP)
        truth = _truth(s.truth(dark=True, **OP), s.truth(photon_flux=FLUX, **OP))
        mask = _truth_mask(s.truth(dark=True, **OP), dark.shape[1:])
        m = _decompose(dark, flat, mask)
        u = _decompose(dark, flat, None)
        for k in keys:
            err[k].append(m[k].value - truth[k])
            err_u[k].append(u[k].value - truth[k])
            ses[k].append(m[k].se)
    report.append(f"\n[issue 6] Monte Carlo: {n} sensors 48x64 (1 % defects, truth mask), {F} dark + {Ff} flat "
                  "frames, illumination=none")
    report.append(f"  {'comp':13s} {'mean err':>11s} {'SEM':>10s} {'err/SEM':>8s} {'sd(err)':>10s} "
                  f"{'rms SE':>10s} {'UNMASKED err/SEM':>17s}")
    bad = []
    for k in keys:
        e, eu = np.array(err[k]), np.array(err_u[k])
        sem = e.std(ddof=1) / math.sqrt(n)
        rse = math.sqrt(np.mean(np.square(ses[k])))
        report.append(f"  {k:13s} {e.mean():11.4g} {sem:10.3g} {e.mean() / sem:+8.2f} {e.std(ddof=1):10.3g} "
                      f"{rse:10.3g} {eu.mean() / sem:+17.1f}")
        if abs(e.mean()) >= 3 * sem:
            bad.append(k)
    assert not bad, "\n".join(report)


def test_stack_analysis_and_classified_mask_pipeline(run):
    """The lazy façade takes masked accumulators unchanged (anova_table/decompose dispatch)."""
    cmask = run["cmask"]
    an = StackAnalysis(_acc(run["dark"], cmask), _acc(run["flat"], cmask), illumination="none")
    comp = an.components()
    assert np.isnan(an.signal_map[cmask]).all() and np.isfinite(an.signal_map[~cmask]).all()
    t = run["truth"]
    for k in ("Ps", "Pt", "Pg"):
        assert abs(comp[k].value - t[k]) < 3 * comp[k].se, (k, comp[k], t[k])
