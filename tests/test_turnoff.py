"""The PTC turnoff (issue 34): the curve followed from below to its first significant
departure, so that what lies beyond the turnover -- an outlier row, an upturn, a second
hump -- cannot move it. Synthetic mean/variance tables with a known turnoff ``T``, shaped
like the real curves of the issue, written to a temporary file and read by ``ares ptc``."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from ares.cli import main

K, READ_VAR, T = 0.25, 4.0, 3000.0  # DN/e-, DN^2, known turnoff (DN)
NPIX, NFR = 10000, 2  # the variance's relative SE is sqrt(2 / (NPIX * (NFR - 1))) = 1.4 %


def _trend(s):
    return READ_VAR + K * s


def _signals():
    low = np.geomspace(30.0, 0.8 * T, 25)
    top = np.linspace(0.82 * T, T, 10)  # 2 % steps up to the turnoff
    beyond = T * (1 + 0.02 * np.arange(1, 16))  # 2 % steps beyond it
    return np.concatenate([low, top, beyond])


def _rolled_off(s):
    """Variance on the line up to T, then falling by 10 % per 2 % of signal (clipping)."""
    v = _trend(np.minimum(s, T))
    return np.where(s > T, v * np.maximum(1 - 5 * (s - T) / T, 0.05), v)


def curve(shape: str, seed: int = 3):
    s = _signals()
    v = _rolled_off(s)
    beyond = np.flatnonzero(s > T)
    if shape == "outlier":  # one saturated row with a variance 2.9x the trend after the turnover
        v[beyond[3]] = 2.9 * _trend(s[beyond[3]])
    elif shape == "upturn":  # the variance drops, then one level rises again (above the peak)
        v[beyond[4]] = 1.3 * _trend(T)
    elif shape == "dip":  # a second, higher hump after the first turnover (+21 %)
        hump = T * 1.21
        on2 = (s > 1.08 * T) & (s <= hump)
        v[on2] = _trend(s[on2]) * 1.02
        after = s > hump
        v[after] = _trend(hump) * np.maximum(1 - 5 * (s[after] - hump) / hump, 0.05)
    rng = np.random.default_rng(seed)
    v = v * (1 + math.sqrt(2.0 / (NPIX * (NFR - 1))) * rng.standard_normal(v.size))
    return s, v


def write(path, s, v):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["mean", "var", "n_pixels", "n_frames"])
        for a, b in zip(s, v):
            w.writerow([a, b, NPIX, NFR])
    return path


def ptc_json(capsys, path) -> dict:
    assert main(["ptc", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def assert_turnoff(d):
    dn, e = d["turnoff_dn"], d["turnoff_e"]
    assert dn["verdict"] == "ok" and e["verdict"] == "ok", (dn, e)
    assert abs(dn["value"] - T) < 0.03 * T, dn
    assert abs(e["value"] - T / K) < 0.03 * T / K, e
    assert dn["unit"] == "DN" and e["unit"] == "e-" and dn["se"] > 0 and e["se"] > 0
    assert d["saturation"]["reached"], d["saturation"]["reason"]


@pytest.mark.parametrize("shape", ["clean", "outlier", "upturn", "dip"])
def test_turnoff_within_3_percent(capsys, tmp_path, shape):
    s, v = curve(shape)
    assert_turnoff(ptc_json(capsys, write(tmp_path / f"{shape}.csv", s, v)))


def test_unsorted_duplicated_and_nan_rows(capsys, tmp_path):
    s, v = curve("outlier")
    rng = np.random.default_rng(5)
    order = rng.permutation(s.size)
    dup = rng.choice(s.size, 6, replace=False)
    s2 = np.concatenate([s[order], s[dup], [math.nan, 1500.0]])
    v2 = np.concatenate([v[order], v[dup], [2.0, math.nan]])
    path = tmp_path / "messy.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["mean", "var", "n_pixels", "n_frames"])
        for a, b in zip(s2, v2):
            w.writerow(["nan" if math.isnan(a) else a, "nan" if math.isnan(b) else b, NPIX, NFR])
    d = ptc_json(capsys, path)
    assert_turnoff(d)
    assert sum(st["reason"] == "non-finite mean or variance" for st in d["level_status"]) == 2


def test_published_definitions_by_name(capsys, tmp_path):
    """EMVA 3.0's maximum variance takes the outlier row; the headline does not."""
    s, v = curve("outlier")
    d = ptc_json(capsys, write(tmp_path / "o.csv", s, v))
    defs = d["turnoff_definitions_dn"]
    assert set(defs) >= {"ptc_turnoff", "emva4_saturation", "max_variance", "lsst_turnoff"}
    outlier = s[np.flatnonzero(s > T)[3]]
    assert defs["max_variance"]["value"] == pytest.approx(outlier)
    assert defs["ptc_turnoff"] == d["turnoff_dn"]
    # the level-to-level rule stops at the first drop, noise included: never above the turnover
    assert 0 < defs["lsst_turnoff"]["value"] <= T
    # the table gives no level's clipped fraction: the 0.2 % criterion finds nothing below the brightest
    # level, which is then only a lower limit (it was "ok", a saturation no data showed)
    assert defs["emva4_saturation"]["verdict"] == "lower limit" and defs["emva4_saturation"]["value"] == s.max()


def test_unreached_turnoff_is_a_lower_limit(capsys, tmp_path):
    s = np.geomspace(30.0, 0.9 * T, 30)
    d = ptc_json(capsys, write(tmp_path / "low.csv", s, _trend(s)))
    assert not d["saturation"]["reached"]
    assert d["turnoff_dn"]["verdict"] == "lower limit" and d["turnoff_dn"]["value"] == pytest.approx(s[-1])
    # every published definition alike: nothing beyond the brightest level, a lower limit, never "ok"
    for name, e in d["turnoff_definitions_dn"].items():
        assert e["verdict"] == "lower limit" and e["value"] == pytest.approx(s[-1]), (name, e)


def test_text_output_shows_the_turnoff(capsys, tmp_path):
    s, v = curve("clean")
    assert main(["ptc", str(write(tmp_path / "c.csv", s, v))]) == 0
    out = capsys.readouterr().out
    assert "PTC turnoff" in out and "PTC turnoff (charge)" in out


def test_one_turnoff_figure_whose_se_is_the_level_spacing(capsys, tmp_path):
    """The turnoff was two figures: "full well, PTC turnoff" 8807 +- 2.6 e- (the signal's SE
    and K's) and "PTC turnoff (charge)" 8810 +- 920 e- (the level spacing), the same level.
    The turnoff is known only to lie between the last level on the curve and the next one, so
    one figure stays, with the rms distance to a point in that interval as its SE."""
    s, v = curve("clean")
    d = ptc_json(capsys, write(tmp_path / "c.csv", s, v))
    assert "ptc_turnoff" not in d["full_well_definitions"]
    dn = d["turnoff_dn"]
    assert dn["value"] == pytest.approx(T) and dn["se"] == pytest.approx(0.02 * T / math.sqrt(3), rel=1e-6)
    assert "level spacing" in dn["note"]
    e = d["turnoff_e"]
    k = d["gain_dn_per_e"]
    assert e["se"] == pytest.approx(e["value"] * math.hypot(dn["se"] / dn["value"], k["se"] / k["value"]))
