"""The truth keys mean what the three-way ANOVA of a dark cube estimates (SCIENCE.md).

A self-contained ANOVA (not the analysis package) on a default-parameter dark cube, at
analog gain 8 so every component is well above quantization. Each estimate is checked
against truth within 4 standard errors from var(MS) = 2 E[MS]^2 / df.
"""

import numpy as np
import pytest

from ares.sim import SensorParams, SimSensor


def anova(y):
    y = y.astype(np.float64)
    F, R, C = y.shape
    m = y.mean()
    mf, mr, mc = y.mean((1, 2)), y.mean((0, 2)), y.mean((0, 1))
    mfr, mfc, mrc = y.mean(2), y.mean(1), y.mean(0)
    ss = {
        "C": F * R * ((mc - m) ** 2).sum(),
        "R": F * C * ((mr - m) ** 2).sum(),
        "F": R * C * ((mf - m) ** 2).sum(),
        "FC": R * ((mfc - mf[:, None] - mc[None, :] + m) ** 2).sum(),
        "FR": C * ((mfr - mf[:, None] - mr[None, :] + m) ** 2).sum(),
        "RC": F * ((mrc - mr[:, None] - mc[None, :] + m) ** 2).sum(),
    }
    e = (y - mfr[:, :, None] - mfc[:, None, :] - mrc[None] + mf[:, None, None] + mr[None, :, None]
         + mc[None, None, :] - m)
    ss["E"] = (e**2).sum()
    df = {"C": C - 1, "R": R - 1, "F": F - 1, "FC": (F - 1) * (C - 1), "FR": (F - 1) * (R - 1),
          "RC": (R - 1) * (C - 1), "E": (F - 1) * (R - 1) * (C - 1)}
    ms = {k: ss[k] / df[k] for k in ss}
    return ms, df, m


def test_anova_of_a_dark_cube_recovers_truth():
    p = SensorParams(rows=48, cols=64).without_defects()
    s = SimSensor(p, 3)
    kw = dict(exposure_s=0.01, analog_gain=8.0, dark=True)
    F = 24
    ms, df, mean = anova(s.render(F, **kw))
    t = s.truth(**kw)
    R, C = p.rows, p.cols
    E = t["Pt"] + t["quantization_dn2"]
    # expected mean squares from truth (temporal: parameters; fixed patterns: realized)
    r = t["realized"]
    exp_ms = {"E": E, "FC": E + R * t["Ct"], "FR": E + C * t["Rt"], "RC": E + F * r["Ps"],
              "F": E + R * t["Ct"] + C * t["Rt"] + R * C * t["frame_global"],
              "C": E + R * t["Ct"] + F * r["Ps"] + F * R * r["Cs"],
              "R": E + C * t["Rt"] + F * r["Ps"] + F * C * r["Rs"]}
    combos = {
        "Pt": ({"E": 1}, 1, E),
        "Ct": ({"FC": 1, "E": -1}, R, t["Ct"]),
        "Rt": ({"FR": 1, "E": -1}, C, t["Rt"]),
        "Ps": ({"RC": 1, "E": -1}, F, r["Ps"]),
        "Cs": ({"C": 1, "FC": -1, "RC": -1, "E": 1}, F * R, r["Cs"]),
        "Rs": ({"R": 1, "FR": -1, "RC": -1, "E": 1}, F * C, r["Rs"]),
        "frame_global": ({"F": 1, "FC": -1, "FR": -1, "E": 1}, R * C, t["frame_global"]),
    }
    for name, (coef, div, truth) in combos.items():
        est = sum(c * ms[k] for k, c in coef.items()) / div
        se = np.sqrt(sum(c * c * 2 * exp_ms[k] ** 2 / df[k] for k, c in coef.items())) / div
        assert abs(est - truth) < 4 * se, (name, est, truth, se)
    # the grand mean is the realized offset (temporal means average out)
    se_o = np.sqrt(exp_ms["F"] / (F * R * C) + exp_ms["C"] / (F * R * C) + exp_ms["R"] / (F * R * C))
    assert mean == pytest.approx(r["o"], abs=4 * se_o + 0.05)
