"""The decomposition against the ARTEMIS simulator's ground truth (ares.sim).

Few replicates of a larger sensor: temporal components are compared with the model
parameters (Pt plus the 1/12 DN^2 quantization the ADC adds), fixed-pattern components
with the values realized by each simulated sensor instance.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

sim = pytest.importorskip("ares.sim")

from ares.analysis import StackAccumulator, decompose_dark  # noqa: E402
from ares.analysis.noise.decompose import StackAnalysis  # noqa: E402

ROWS, COLS, F, NREP = 96, 128, 10, 8
CLEAN = dict(hot_rate_ppm=0, warm_rate_ppm=0, rts_rate_ppm=0, dead_rate_ppm=0, stuck_rate_ppm=0,
             noisy_rate_ppm=0, crosstalk_pct=0.0)


def _acc(x):
    a = StackAccumulator(x.shape[1:])
    for f in x:
        a.add(f)
    return a


@pytest.mark.slow
@pytest.mark.parametrize("regime", ["default", "row-noise heavy"])
def test_dark_against_sim_truth(regime, report):
    extra = {} if regime == "default" else dict(row_temporal_dn=1.5, row_fpn_dn=0.2, col_fpn_dn=2.0)
    params = sim.SensorParams(rows=ROWS, cols=COLS, **CLEAN, **extra)
    zs = {k: [] for k in ("Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global")}
    rows = []
    for seed in range(NREP):
        s = sim.SimSensor(params, seed)
        x = s.render(F, exposure_s=0.01, dark=True)
        tr = s.truth(exposure_s=0.01, dark=True)
        d = decompose_dark(_acc(x))
        truth = {k: tr[k] for k in ("Ct", "Rt", "frame_global")}
        truth["Pt"] = tr["Pt"] + tr["quantization_dn2"]
        truth.update({k: tr["realized"][k] for k in ("Cs", "Rs", "Ps")})
        for k in zs:
            zs[k].append((d[k].value - truth[k]) / d[k].se)
        rows.append((truth, d))
    report.append(f"\n[sim truth] dark, {regime}: {ROWS}x{COLS}, F={F}, {NREP} sensors (spatial: realized values)")
    report.append(f"  {'comp':13s} {'truth(avg)':>11s} {'est(avg)':>11s} {'mean z':>7s} {'rms z':>6s}")
    for k, z in zs.items():
        t = np.mean([r[0][k] for r in rows])
        e = np.mean([r[1][k].value for r in rows])
        z = np.array(z)
        # bias: mean error over sensors within 3 standard errors of that mean (the SE
        # of one estimate taken as the RMS of the reported SEs: with df = F-1 = 9 a
        # single z is far from Gaussian for frame_global)
        err = np.mean([r[1][k].value - r[0][k] for r in rows])
        sem = math.sqrt(np.mean([r[1][k].se ** 2 for r in rows]) / NREP)
        report.append(f"  {k:13s} {t:11.5g} {e:11.5g} {z.mean():7.2f} {math.sqrt((z**2).mean()):6.2f}  bias/SEM {err / sem:+.2f}")
        assert abs(err) < 3 * sem, (k, err, sem)


@pytest.mark.slow
def test_flat_against_sim_truth(report):
    params = sim.SensorParams(rows=ROWS, cols=COLS, **CLEAN, prnu_pct=1.0, col_gain_pct=0.5, row_gain_pct=0.4)
    kw = dict(exposure_s=0.01, photon_flux=2e5)
    res = []
    for seed in range(4):
        s = sim.SimSensor(params, 100 + seed)
        dark = s.render(F, exposure_s=0.01, dark=True)
        flat = s.render(F, **kw)
        tr = s.truth(**kw)
        an = StackAnalysis(_acc(dark), _acc(flat), illumination="none")
        c = an.components()
        truth = dict(G=tr["G"], q=tr["q"], delta=tr["delta"], **{k: tr["realized"][k] for k in ("Cg", "Rg", "Pg")})
        res.append((truth, c))
    report.append(f"\n[sim truth] flat: {ROWS}x{COLS}, F={F}, 4 sensors, q ~ {res[0][0]['q']:.0f} e- (gain NU: realized)")
    for k in ("G", "Cg", "Rg", "Pg", "q", "delta"):
        t = np.mean([r[0][k] for r in res])
        e = np.mean([r[1][k].value for r in res])
        z = [(r[1][k].value - r[0][k]) / r[1][k].se for r in res]
        err = np.mean([r[1][k].value - r[0][k] for r in res])
        sem = math.sqrt(np.mean([r[1][k].se ** 2 for r in res]) / len(res))
        report.append(f"  {k:6s} truth {t:11.5g} est {e:11.5g}  z = {', '.join(f'{v:+.1f}' for v in z)}  bias/SEM {err / sem:+.2f}")
        assert abs(err) < 3 * sem, (k, err, sem)
