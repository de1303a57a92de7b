"""The physical-range guard (issue 34): a figure outside its physical range -- a negative
variance or dark current, a dark current from a variance at the quantization floor -- is
never verdict "ok", but an upper limit or "not available" with the reason."""

from __future__ import annotations

import json

import numpy as np

from ares.analysis.dark_current import dark_current
from ares.analysis.estimate import Estimate
from ares.analysis.physical import in_range
from ares.cli import main


def test_in_range_closed_form():
    assert in_range(Estimate(2.0, 0.5, "DN^2"), 0.0).verdict == "ok"
    near = in_range(Estimate(-1.0, 0.5, "DN^2"), 0.0)  # 2 SE below zero: consistent with 0
    assert near.verdict == "upper limit" and near.value == -1.0 + 3 * 0.5 and "physical minimum" in near.note
    far = in_range(Estimate(-17.0, 1.0, "DN^2"), 0.0)
    assert far.verdict == "not available" and "17 SE below" in far.note
    assert in_range(Estimate(120.0, 1.0, ""), maximum=100.0).verdict == "not available"  # SNR above sqrt(well)
    assert in_range(Estimate(101.0, 1.0, ""), maximum=100.0).verdict == "lower limit"


def _row_col_centred_dark(seed=0, n=8, shape=(40, 48)):
    """A dark stack whose fixed pattern has every row and column mean removed (as a camera's
    row/column offset correction does): the ANOVA's row and column variances come out
    significantly below zero."""
    rng = np.random.default_rng(seed)
    fpn = rng.normal(0, 8, shape)
    fpn -= fpn.mean(axis=1, keepdims=True)
    fpn -= fpn.mean(axis=0, keepdims=True)
    x = 300 + fpn + rng.normal(0, 1.0, (n,) + shape)
    return np.round(x).astype(np.uint16)


def test_analyze_dark_stack_negative_row_column_variances(tmp_path, capsys):
    np.save(tmp_path / "dark.npy", _row_col_centred_dark())
    assert main(["analyze", str(tmp_path / "dark.npy"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for k in ("Rs", "Cs"):
        assert out[k]["verdict"] != "ok", out[k]
        assert out[k]["verdict"] == "not available" and "below its physical minimum" in out[k]["note"]
    assert out["Ps"]["verdict"] == "ok" and out["Ps"]["value"] > 0


def test_every_variance_component_never_negative_and_ok(tmp_path, capsys):
    np.save(tmp_path / "dark.npy", _row_col_centred_dark(seed=4))
    assert main(["analyze", str(tmp_path / "dark.npy"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for k in ("Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global"):
        assert not (out[k]["verdict"] == "ok" and out[k]["value"] < 0), (k, out[k])


T = np.array([0.001, 0.002, 0.005, 0.01, 0.02, 0.05])


def test_negative_dark_current_from_the_mean_is_not_ok():
    mean = 20.0 - 50.0 * T + np.array([0.01, -0.01, 0.0, 0.01, -0.01, 0.0])  # a falling offset, -50 DN/s
    dc = dark_current(T, mean, Estimate(0.01, 1e-4, "DN/e-"))
    assert dc.rate_dn_per_s.verdict == "not available" and dc.rate_e_per_s.verdict == "not available"
    assert "below its physical minimum" in dc.rate_e_per_s.note


def test_slightly_negative_dark_current_is_an_upper_limit():
    rng = np.random.default_rng(1)
    mean = 20.0 + 0.01 * rng.standard_normal(T.size)
    dc = dark_current(T, mean, Estimate(0.2, 1e-3, "DN/e-"))
    e = dc.rate_e_per_s
    assert e.verdict in ("ok", "upper limit")
    assert not (e.verdict == "ok" and e.value < 0)


def test_dark_current_from_a_variance_at_the_quantization_floor():
    """An 8-bit camera: dark noise below 0.24 DN is quantization noise (EMVA 1288 4.0 Linear
    Section 6.6); with K = 0.01 DN/e- a slope of 0.0013 DN^2/s would read as 1.3e7 e-/s."""
    var = 0.04 + 1.3 * T  # sigma 0.2 DN
    dc = dark_current(T, 10.0 + 0.001 * T, Estimate(0.01, 1e-4, "DN/e-"), var)
    assert dc.rate_from_variance_e_per_s.verdict == "not available"
    assert "quantization" in dc.rate_from_variance_e_per_s.note


def test_a_small_but_significant_variance_rise_keeps_its_value_and_error():
    """A rise below 1/12 DN^2 over the exposures is still a measured slope (quantization adds a
    constant, not a slope, once the noise dithers it): value +- its error, as Section 7.1 asks."""
    rng = np.random.default_rng(4)
    var = 0.5 + 1.3 * T + 0.002 * rng.standard_normal(T.size)  # rises 0.064 DN^2, SE of the slope ~1 %
    dc = dark_current(T, 10.0 + 0.001 * T, Estimate(0.01, 1e-4, "DN/e-"), var)
    e = dc.rate_from_variance_e_per_s
    assert e.verdict == "ok" and abs(e.value - 1.3 / 0.01**2) < 3 * e.se


def test_negative_dark_current_from_the_variance_is_not_ok():
    var = 2.0 - 40.0 * T + np.array([0.001, -0.001, 0.0, 0.001, -0.001, 0.0])
    dc = dark_current(T, 10.0 + 0.001 * T, Estimate(0.2, 1e-3, "DN/e-"), var)
    assert dc.rate_from_variance_e_per_s.verdict == "not available"
