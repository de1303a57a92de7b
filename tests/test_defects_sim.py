"""Defect identification on the simulated sensor (ares.sim) against its ground truth.

VGA, 100 dark frames + 20 flat frames, 1 % defective pixels (hot, warm, RTS, dead, stuck,
noisy) and 3 bad columns, default thresholds. The operating point -- 5 C die
temperature, 20 s exposure -- places the simulator's hot pixels (2000 e-/s x [0.5,1.5] at
60 C, i.e. 8.5-25 e-/s at 5 C) above hot_e_per_s = 5 and its warm pixels (1.3-3.8 e-/s)
between warm_e_per_s = 1 and 5; the flat is ~50 % of full well at the same exposure.

Detectability limits used for recall: every injected hot, warm, dead, stuck and noisy
pixel is above them by construction (see the numbers above and dead_response = 0.3 <
dead_fraction = 0.5, noisy_factor 5 -> variance x7); RTS pixels count when their
amplitude is >= 5x the pixel's temporal noise (the stated RTS limit).
"""

import numpy as np
import pytest

sim = pytest.importorskip("ares.sim")

from ares.analysis.defects import DefectThresholds, classify_stack, masked_population_stats, pixel_stats  # noqa: E402
from ares.analysis.defects.result import PIXEL_CLASSES, primary_class  # noqa: E402

TRUE_CLASSES = ("hot", "warm", "dead", "stuck", "noisy", "rts")
OP = dict(exposure_s=20.0, temperature_c=5.0)
RATES = dict(hot_rate_ppm=2000, warm_rate_ppm=2000, rts_rate_ppm=1500, dead_rate_ppm=1500,
             stuck_rate_ppm=1000, noisy_rate_ppm=2000)  # 1 % of the pixels in all


@pytest.fixture(scope="module")
def run():
    p = sim.SensorParams(rows=480, cols=640, bad_columns=3, rts_amplitude_e=30.0, **RATES)
    s = sim.SimSensor(p, 1)
    dark = s.render(100, dark=True, **OP)
    flat = s.render(20, photon_flux=500.0, **OP)
    truth = s.truth(dark=True, **OP)
    gain = p.gain_dn_per_e()
    res = classify_stack(dark, flat, gain_dn_per_e=gain, exposure_s=OP["exposure_s"])
    return dict(p=p, dark=dark, flat=flat, truth=truth, res=res, gain=gain)


def _tables(run):
    d = run["truth"]["defects"]
    shape = run["dark"].shape[1:]
    tm = np.full(shape, "", "U13")
    for c in TRUE_CLASSES:
        tm[d[c]] = c
    prim = primary_class(run["res"].mask)
    pred = np.where(prim >= 0, np.array(PIXEL_CLASSES)[np.maximum(prim, 0)], "")
    return tm, pred


def _confusion_text(tm, pred, rts_ok):
    cols = [""] + list(PIXEL_CLASSES)
    head = "true \\ predicted".ljust(22) + "".join((c or "good")[:8].rjust(9) for c in cols)
    lines = [head]
    rows = [("good", tm == "")] + [(c, tm == c) for c in TRUE_CLASSES if c != "rts"]
    rows += [("rts >= 5 sigma", (tm == "rts") & rts_ok), ("rts < 5 sigma", (tm == "rts") & ~rts_ok)]
    for name, sel in rows:
        lines.append(name.ljust(22) + "".join(str(int(np.count_nonzero(sel & (pred == c)))).rjust(9) for c in cols))
    return "\n".join(lines)


def test_sim_confusion_matrix(run):
    tm, pred = _tables(run)
    res, truth = run["res"], run["truth"]
    st = pixel_stats(run["dark"])
    sigma_t = float(np.sqrt(np.median(st.var)))  # the pixels' temporal noise, DN
    amp_dn = truth["defects"]["properties"]["rts_amplitude_e"] * run["gain"]
    rts_ok = np.zeros(tm.shape, bool)
    rts_ok[truth["defects"]["rts"]] = amp_dn >= 5 * sigma_t
    text = _confusion_text(tm, pred, rts_ok)
    npix = tm.size
    fp = int(np.count_nonzero((tm == "") & (pred != "")))
    msg = (f"\n{text}\nfalse positives: {fp} in {npix} pixels = {fp / npix * 1e6:.2f} per megapixel"
           f"\nbad columns found {[c['x'] for c in res.bad_columns]} truth {truth['defects']['bad_columns'].tolist()}"
           f"\nRTS: {res.rts_note}; 5 sigma = {5 * sigma_t:.2f} DN")
    print(msg)
    for c in TRUE_CLASSES:
        sel = (tm == c) & (rts_ok if c == "rts" else True)
        n = int(sel.sum())
        assert n > 50, msg
        hit = int(np.count_nonzero(sel & (pred == c)))
        assert hit >= 0.99 * n, f"recall of {c}: {hit}/{n}{msg}"
    assert fp / (npix / 1e6) <= 1.0, msg
    assert sorted(c["x"] for c in res.bad_columns) == sorted(truth["defects"]["bad_columns"].tolist()), msg
    assert res.bad_rows == [], msg


def test_sim_masked_temporal_variance_unbiased(run):
    """With defects masked, the mean per-pixel temporal variance matches the truth within 3 SE.

    Truth = Pt + Ct + Rt + frame-global + 1/12 (realized, from the simulator); its SE is
    dominated by the 100 frame-global draws: var(s2) ~ 2 v^2/(F-1) per independent draw.
    """
    t = run["truth"]
    r = t["realized"]
    truth = r["Pt"] + r["Ct"] + r["Rt"] + r["frame_global"] + t["quantization_dn2"]
    st = pixel_stats(run["dark"])
    F = st.n_frames
    R, C = st.shape
    k = np.sqrt(2.0 / (F - 1))
    se = np.sqrt((k * truth) ** 2 / (R * C) + (k * r["Rt"]) ** 2 / R + (k * r["Ct"]) ** 2 / C
                 + (k * r["frame_global"]) ** 2)
    masked = masked_population_stats(st, run["res"].defective())
    raw = masked_population_stats(st, np.zeros(st.shape, bool))
    msg = f"truth {truth:.4f} DN^2, SE {se:.4f}; masked {masked['temporal_var_dn2']:.4f}, raw {raw['temporal_var_dn2']:.4f}"
    print("\n" + msg)
    assert abs(masked["temporal_var_dn2"] - truth) < 3 * se, msg
    assert abs(raw["temporal_var_dn2"] - truth) > 3 * se, msg


def test_sim_counts_fall_as_thresholds_rise(run):
    dark, flat, gain = run["dark"], run["flat"], run["gain"]
    a = classify_stack(dark, flat, gain_dn_per_e=gain, exposure_s=20.0,
                       thresholds=DefectThresholds(hot_e_per_s=15.0, warm_e_per_s=2.5, dead_fraction=0.2))
    b = run["res"]
    assert a.flag_counts["hot"] < b.flag_counts["hot"]
    assert a.flag_counts["dead"] < b.flag_counts["dead"]
    assert a.flag_counts["hot"] + a.flag_counts["warm"] <= b.flag_counts["hot"] + b.flag_counts["warm"]
