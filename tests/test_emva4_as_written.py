"""EMVA 1288 Release 4.0 Linear as written, on the reference CCD (``../shared/data/``): every
figure below is computed here again in plain numpy/scipy straight from the text (Sections
2.3, 2.7, 4.2, 4.3, 6.6, 7.1 and 8.1 of the Linear document, Eqs. 44 - 48 of the General
one), not from ARES's code, and ``ares emva --json`` must give it: mu_p.sat, mu_e.sat,
SNR_max and DR from the photons at the saturation step (Eq. 24) within 0.2 %, the Eq. 51
check with the B-spline over equal intervals up to saturation, and the row/column split of
Eqs. 36, 39 - 41, 43. ARES's own methods appear only with ``--extension``, beside them."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

DESC = Path(__file__).resolve().parents[2] / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / \
    "EMVA1288_Data.txt"
on_ccd = pytest.mark.skipif(not DESC.is_file(), reason="the EMVA reference data set is not in ../shared/data/")


def _pair(desc, lv):
    from ares.hardware.emva_descriptor import iter_level

    a, b = (np.asarray(x, np.float64) for x in list(iter_level(desc, lv))[:2])
    mu0, mu1 = a.mean(), b.mean()
    var = np.mean((a - b) ** 2) / 2 - (mu0 - mu1) ** 2 / 2  # Eq. 18
    return (mu0 + mu1) / 2, var, max(a.max(), b.max()), a, b


@pytest.fixture(scope="module")
def text():
    """The Linear evaluation from the text (Section 6.6), independent of ares.analysis."""
    from ares.hardware.emva_descriptor import read_descriptor

    desc = read_descriptor(DESC)
    tb = desc.temporal_bright
    up = np.array([lv.photons for lv in tb])
    texp = np.array([lv.exposure_s for lv in tb])
    stats = [_pair(desc, lv) for lv in tb]
    darks = [_pair(desc, desc.dark_for(lv, "temporal")) for lv in tb]
    ymax = max(s[2] for s in stats)  # "first find the maximum possible value"
    frac = np.array([(np.count_nonzero(s[3] == ymax) + np.count_nonzero(s[4] == ymax)) / (2 * s[3].size)
                     for s in stats])
    o = np.argsort(up)
    up, texp, frac = up[o], texp[o], frac[o]
    mu = np.array([stats[i][0] - darks[i][0] for i in o])
    var = np.array([stats[i][1] - darks[i][1] for i in o])
    s2dark = np.array([darks[i][1] for i in o])
    first_over = int(np.flatnonzero(frac > 0.002)[0])
    isat = first_over - 1  # the brightest step with at most 0.2 % at the maximum value
    ysat = mu[isat]
    rng = (mu > 0) & (mu <= 0.7 * ysat)  # "between the minimum value and 70 % saturation"
    R = float(np.dot(up[rng], mu[rng]) / np.dot(up[rng], up[rng]))  # Eq. 49, zero offset
    K = float(np.polyfit(mu[rng], var[rng], 1)[0])  # Eq. 50, offset and slope
    eta = R / K  # Eq. 52
    s2d = s2dark[np.argmin(texp)]  # temporal dark noise at the lowest exposure
    mu_p_min = (math.sqrt(s2d / K**2 + 0.25) + 0.5) / eta  # Eq. 26 (sigma_d^2 + sigma_q^2/K^2 = s2_y.dark/K^2)
    mu_p_sat = up[isat]  # "the number of photons which corresponds to the maximum measured digital value"
    mu_e_sat = eta * mu_p_sat  # Eq. 24
    return dict(desc=desc, up=up, mu=mu, var=var, isat=isat, ysat=ysat, rng=rng, K=K, R=R, eta=eta, ymax=ymax,
                mu_p_sat=mu_p_sat, mu_e_sat=mu_e_sat, SNR_max=math.sqrt(mu_e_sat),  # Eq. 55
                DR=mu_p_sat / mu_p_min)  # Eq. 28


@pytest.fixture(scope="module")
def out():
    import contextlib
    import io

    from ares.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["emva", str(DESC), "--json", "--extension", "rowcol_corrected", "--extension",
                     "mu_e_sat_fit", "--extension", "eq51_noise_floor"]) == 0
    return json.loads(buf.getvalue())


@on_ccd
@pytest.mark.parametrize("name", ["mu_p_sat", "mu_e_sat", "SNR_max", "DR"])
def test_saturation_figures_follow_eq_24(text, out, name):
    """On the reference CCD within 0.2 % of the Eq. 24-based values (the photons measured at
    the saturation step, times eta); the former (mu_y.sat - mu_y.dark)/K is 0.82 % lower and
    appears only as the labelled option mu_e_sat_fit."""
    v = out["values"]
    assert v[name]["value"] == pytest.approx(text[name], rel=0.002)
    assert v[name]["verdict"] == "lower limit"  # no step has 0.1 - 0.2 % of its pixels at 4095
    fit = v["mu_e_sat.mu_e_sat_fit"]
    assert "ARES option mu_e_sat_fit" in fit["note"]
    assert fit["value"] == pytest.approx(text["ysat"] / text["K"], rel=0.002)
    assert fit["value"] < 0.995 * v["mu_e_sat"]["value"]


@on_ccd
def test_maximum_value_found_in_the_data(text, out):
    assert text["ymax"] == 4095
    assert any("maximum value 4095 DN, found in the data" in n for n in out["notes"])


def _eq51(text, P):
    """Eq. 51 as written: the General document's cubic B-spline (Eqs. 44 - 46: P equal
    intervals of 0 .. mu_y.sat - mu_y.dark, basis beta3(x/d - (p - 1)), p = 0 .. P + 2: the
    uniform spline on the knots d * (-3 .. P + 3)) fitted by plain least squares (Eq. 47) to
    the photon transfer curve up to saturation; its derivative at the steps within 0 - 70 %."""
    from scipy.interpolate import BSpline

    x = text["mu"][: text["isat"] + 1]
    y = text["var"][: text["isat"] + 1]
    d = text["ysat"] / P
    t = d * np.arange(-3, P + 4)
    A = BSpline.design_matrix(x, t, 3).toarray()
    coef = np.linalg.lstsq(A, y, rcond=None)[0]
    ki = BSpline(t, coef, 3).derivative()(text["mu"][text["rng"]])
    return float(np.mean(np.abs(ki - text["K"])) / text["K"])


@on_ccd
def test_eq51_as_written(text, out):
    """The text's local-slope check holds on this CCD (2.89 % < 3 %, P = 6: "6 to 8
    intervals" for ~50 steps, General Section 6.6); ARES's noise-floor variant (4.2 %, does
    not hold) is reported beside it, labelled, never as the verdict."""
    e = out["eq51"]["as_written"]
    assert e["intervals"] == 6
    assert e["mean_rel_dev_pct"] / 100 == pytest.approx(_eq51(text, 6), rel=1e-6)
    assert e["holds"] is True and out["linear_model_holds"] is True
    assert 2.8 < e["mean_rel_dev_pct"] < 3.0
    nf = out["eq51"]["eq51_noise_floor"]
    assert nf["holds"] is False and "beyond the text" in nf["option"]
    assert any(n.startswith("ARES option eq51_noise_floor") for n in out["notes"])


def _highpass(img):
    """Section 8.1: the image smoothed by a 7 x 7 box, an 11 x 11 box and a 3 x 3 binomial
    filter, one after the other, subtracted from it; only what the filters reach completely
    (half widths 3 + 5 + 1 = 9 at each border)."""
    from scipy.ndimage import convolve1d

    s = img
    for k in (np.full(7, 1 / 7), np.full(11, 1 / 11), np.array([0.25, 0.5, 0.25])):
        s = convolve1d(convolve1d(s, k, axis=0), k, axis=1)
    return (img - s)[9:-9, 9:-9]


def _split(frames):
    """Eqs. 33 - 36, 39 - 41 and 43: column, row and pixel variances of the averaged image
    after the high-pass, with the temporal variance of Eq. 57 (white-noise terms)."""
    L = len(frames)
    avg = np.mean(frames, axis=0)
    s2_temporal = float(np.mean(np.var(frames, axis=0, ddof=1)))  # Eq. 57
    y = _highpass(avg)
    M, N = y.shape
    mu = y.mean()
    s2 = np.mean((y - mu) ** 2) - s2_temporal / L  # Eqs. 35, 36
    cav = np.mean((y.mean(axis=0) - mu) ** 2) - s2_temporal / (L * M)  # Eq. 41
    rav = np.mean((y.mean(axis=1) - mu) ** 2) - s2_temporal / (L * N)
    inv = np.array([[M * (N - 1), N, -N], [M, N * (M - 1), -M], [-M * N, -N * M, N * M]]) / (M * N - M - N)
    col, row, pix = inv @ np.array([cav, rav, s2])  # Eq. 43
    return {"col": col, "row": row, "pix": pix, "total": col + row + pix, "mean": float(avg.mean())}


@pytest.fixture(scope="module")
def splits(text):
    from ares.hardware.emva_descriptor import iter_level

    desc = text["desc"]
    lv = desc.spatial_bright[0]
    dk = desc.dark_for(lv, "spatial")
    return (_split(np.array([np.asarray(f, np.float64) for f in iter_level(desc, dk)])),
            _split(np.array([np.asarray(f, np.float64) for f in iter_level(desc, lv)])))


@on_ccd
@pytest.mark.parametrize("part", ["col", "row", "pix"])
def test_row_column_split_by_eqs_36_39_41(text, out, splits, part):
    """DSNU1288 and PRNU1288 .col/.row/.pix (Eqs. 66, 67) from the text's split, within a
    third of the reported SE (the only difference: ARES removes the frame offsets from the
    temporal variance of Eq. 57, a ~0.5 % change of a term that is itself 1/L of the total).
    The filter-gain / row-column-temporal variant is beside them, labelled, not instead."""
    v = out["values"]
    dark, bright = splits
    K = v["K"]["value"]
    for key, s2, scale in (("DSNU1288_" + part, dark[part], 1 / K),
                           ("PRNU1288_" + part, bright[part] - dark[part], 100 / (bright["mean"] - dark["mean"]))):
        e, ext = v[key], v[f"{key}.rowcol_corrected"]
        assert "ARES option rowcol_corrected" in ext["note"] and "ARES option" not in e["note"]
        if e["verdict"] == "ok":
            assert e["value"] == pytest.approx(math.sqrt(s2) * scale, abs=0.3 * e["se"]), key
        else:  # an upper limit: the variance is not above twice its SE
            assert e["verdict"] == "upper limit" and s2 < 2 * (e["value"] / scale) ** 2, key
    if part == "row":  # the numbers: the text's DSNU.row 0.232 e-, the option's < 0.096 e-
        assert v["DSNU1288_row"]["value"] == pytest.approx(0.232, abs=0.002)
        assert v["DSNU1288_row.rowcol_corrected"]["verdict"] == "upper limit"


@on_ccd
def test_dark_current_value_with_sigma(text, out):
    """Section 7.1: the dark current is reported with its one-sigma error from the
    regression of the dark means over the exposure times (divided by K)."""
    from ares.hardware.emva_descriptor import iter_level

    desc = text["desc"]
    seen = {}
    for lv in desc.temporal_bright:
        dk = desc.dark_for(lv, "temporal")
        if dk.exposure_s not in seen:
            seen[dk.exposure_s] = float(np.mean([np.mean(np.asarray(f, np.float64)) for f in
                                                 list(iter_level(desc, dk))[:2]]))
    t = np.array(sorted(seen))
    m = np.array([seen[x] for x in t])
    (b, a), cov = np.polyfit(t, m, 1, cov=True)
    e = out["values"]["mu_I_mean"]
    assert e["verdict"] == "ok"
    assert e["value"] == pytest.approx(b / text["K"], rel=1e-3)
    assert e["se"] == pytest.approx(math.sqrt(cov[0, 0]) / text["K"], rel=0.02)


def _clipping_set(tmp_path, top=4000):
    """A 12-bit set (Release 3.0 descriptor) whose camera clips at ``top`` < 2^12 - 1:
    14 levels of 30 x 40 pixels, gain 1 DN/e-, the brightest ones clipped."""
    from PIL import Image

    rng = np.random.default_rng(11)
    lines = ["# clipping at a maximum value below 2^k - 1", "v 3.0", "n 12 40 30"]
    means = np.r_[np.linspace(150, 3400, 10), 3650, 3760, 3850, 3990]
    frames = {}
    for k, m in enumerate(means):
        lines.append(f"b {1000.0 * (k + 1)} {2 * m}")
        for j in range(2):
            img = np.minimum(rng.poisson(m, (30, 40)) + 100, top)
            frames[f"b_{k:03d}_{j}"] = img
            lines.append(f"i images\\b_{k:03d}_{j}.png")
    for k in range(len(means)):
        lines.append(f"d {1000.0 * (k + 1)}")
        for j in range(2):
            frames[f"d_{k:03d}_{j}"] = rng.poisson(4, (30, 40)) + 100
            lines.append(f"i images\\d_{k:03d}_{j}.png")
    (tmp_path / "images").mkdir()
    for name, img in frames.items():
        Image.fromarray(img.astype(np.uint16)).save(tmp_path / "images" / f"{name}.png")
    (tmp_path / "data.txt").write_text("\n".join(lines) + "\n")
    return tmp_path / "data.txt", means, frames


def test_saturation_at_a_maximum_value_found_below_2k_minus_1(tmp_path, capsys):
    """Section 6.6: "first find the maximum possible value", which may be below 2^k - 1: a
    camera clipping at 4000 DN gets its saturation step from the fraction of pixels at 4000
    (the brightest step with at most 0.2 % there, counted here from the images), not
    "saturation not reached" as a search for 4095 would say."""
    from ares.cli import main

    path, means, frames = _clipping_set(tmp_path)
    frac = np.array([np.mean([np.mean(frames[f"b_{k:03d}_{j}"] == 4000) for j in range(2)])
                     for k in range(len(means))])
    isat = int(np.flatnonzero(frac > 0.002)[0]) - 1
    assert main(["emva", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert any("maximum value 4000 DN, found in the data" in n and "2^k - 1 = 4095" in n for n in out["notes"])
    assert out["saturation"].startswith(f"mu_y.sat at level {isat}")
    assert out["values"]["mu_p_sat"]["value"] == pytest.approx(2 * means[isat])
