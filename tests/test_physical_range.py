"""The physical-range guard (issue 34): a figure outside its physical range -- a negative
variance or dark current, a dark current from a variance at the quantization floor -- is
never verdict "ok", but an upper limit or "not available" with the reason."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from ares.analysis.ptc.dark_current import dark_current
from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.physical import in_range
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


# ---------------------------------------------------------------- through the commands
# Out-of-range inputs fed to `ares emva` and `ares analyze` as a user would: no "ok" verdict
# for the figures they make impossible, in the JSON nor in the printed table. (`ares ptc`
# prints no SNR or dark current; its negative-variance levels are excluded with a reason,
# tests/test_turnoff.py and tests/test_ptc_command.py.)

def _verdicts(tree, path=""):
    """{dotted path: (value, verdict)} of every estimate in a JSON tree."""
    out = {}
    if isinstance(tree, dict):
        if "verdict" in tree and "value" in tree:
            out[path] = (tree["value"], tree["verdict"])
        for k, v in tree.items():
            out.update(_verdicts(v, f"{path}.{k}" if path else k))
    return out


def _emva(capsys, desc, release, as_json=True):
    assert main(["emva", str(desc), "--release", release] + (["--json"] if as_json else [])) == 0
    out = capsys.readouterr().out
    return json.loads(out) if as_json else out


def _shown_as_verdict(text: str, key: str) -> bool:
    """A figure's row in `ares emva`'s table shows "n/a" or a limit ("< x", "> x"), not a value."""
    lines = text.splitlines()
    end = next(ln for ln in lines if ln.startswith("quantity")).index("value") + len("value")
    line = next(ln for ln in lines if ln.split()[:1] == [key])
    cell = line[:end]  # quantity, symbol, value (right-aligned under "value"; the reason follows)
    return "n/a" in cell or re.search(r"[<>] ?[\d.]", cell) is not None


@pytest.fixture(scope="module")
def qe_above_one(tmp_path_factory):
    """Photons declared 1.6x too low (a QE of 128 %): SNR_max = sqrt(eta mu_p.sat) above
    sqrt(mu_p.sat), which no sensor reaches; and a dark level falling 2000 DN/s with exposure."""
    from emva_pngset import write_set

    return write_set(tmp_path_factory.mktemp("qe"), qe=0.8, photons_scale=1 / 1.6, dark_slope_dn_per_s=-2000.0)


@pytest.mark.parametrize("release,keys", [("4.0-linear", ("SNR_max", "SNR_max_db", "SNR_max_inv", "mu_I_mean")),
                                          ("4.0-general", ("SNR_max", "SNR_max_db", "SNR_max_inv")),
                                          ("3.0", ("SNR_max",))])
def test_emva_snr_above_sqrt_of_the_photons_is_never_ok(capsys, qe_above_one, release, keys):
    d = _emva(capsys, qe_above_one, release)
    v = _verdicts(d.get("values", d))
    for k in keys:
        assert v[k][1] != "ok", (release, k, v[k])
    if release == "4.0-linear":
        assert v["SNR_max"][1] == "not available"
        text = _emva(capsys, qe_above_one, release, as_json=False)
        for k in keys:
            assert _shown_as_verdict(text, k), k


def test_emva_dark_current_from_a_variance_at_the_quantization_floor(capsys, tmp_path):
    """An 8-bit camera whose dark noise (0.15 DN) is below the quantization floor: the dark
    current from the variance's slope is not a measurement."""
    from emva_pngset import write_set

    desc = write_set(tmp_path, bits=8, K=0.02, dark_sigma_dn=0.15, qe=0.6)
    v = _verdicts(_emva(capsys, desc, "4.0-linear")["values"])
    assert v["mu_I_var"][1] != "ok" and v["mu_I_var"][1] == "not available", v["mu_I_var"]
    text = _emva(capsys, desc, "4.0-linear", as_json=False)
    assert _shown_as_verdict(text, "mu_I_var")


def test_analyze_negative_variances_in_json_and_text(tmp_path, capsys):
    """`ares analyze` on a dark stack whose row and column means were removed: the row and
    column variances come out far below 0 -- not "ok" in the JSON, not a bare number in the text."""
    np.save(tmp_path / "dark.npy", _row_col_centred_dark(seed=2))
    assert main(["analyze", str(tmp_path / "dark.npy"), "--json"]) == 0
    v = _verdicts(json.loads(capsys.readouterr().out))
    for k, (val, verdict) in v.items():
        assert not (verdict == "ok" and val is not None and val < 0), (k, val)
    assert v["Rs"][1] != "ok" and v["Cs"][1] != "ok"
    assert main(["analyze", str(tmp_path / "dark.npy")]) == 0
    text = capsys.readouterr().out
    for k in ("Rs", "Cs"):
        line = next(ln for ln in text.splitlines() if ln.split()[:1] == [k])
        assert "n/a" in line or "<" in line, line


def test_key_figure_snr_is_judged_against_sqrt_of_the_full_well():
    """The report's "SNR max (measured)" (key figures: CSV, HDF5, PDF) is judged against sqrt
    of the run's full well: with the well the curve shows, the largest SNR (shot-noise
    limited, below sqrt(well)) stays "ok" with an SE; against a well it exceeds (a full well
    measured too low) it is not available, saying why."""
    from types import SimpleNamespace

    from ares.analysis.ptc.levels import LevelStats
    from ares.analysis.ptc.photon_transfer import analyze_ptc
    from ares.report.tables import PtcGroup, _snr_max, compute_key_figures

    K, n = 0.25, 20
    q = np.r_[np.geomspace(100, 16000, n - 4), [16000 * 1.05, 16000 * 1.1, 16000 * 1.2, 16000 * 1.3]]
    s = K * np.minimum(q, 16000)
    v = K * K * np.minimum(q, 16000) + 4.0
    v[n - 4:] = 0.5  # the saturated plateau: every pixel clipped
    bright = [LevelStats(100 + a, b, 100000, 16, 0.0) for a, b in zip(s, v)]
    dark = [LevelStats(100.0, 4.0, 100000, 16) for _ in s]
    res = analyze_ptc(bright, dark, photons=q / 0.6)
    g = PtcGroup(1.0, [], res, {}, list(q / 1e6), [None] * n, list(q / 0.6))
    kf = compute_key_figures(SimpleNamespace(analyses={}, stages=[], complete=True), [g])
    well, snr = kf["full_well_e"]["value"], kf["snr_max"]
    assert well == pytest.approx(16000, rel=0.05)
    assert snr["verdict"] == "ok" and snr["value"] < math.sqrt(well) and snr["se"] > 0
    assert kf["snr_max_db"]["verdict"] == "ok"
    low = _snr_max(res, 0.5 * snr["value"] ** 2)  # SNR = 1.41 sqrt(well)
    assert low.verdict == "not available" and "physical maximum" in low.note


def test_a_signed_figure_not_resolved_from_zero_is_a_limit_never_ok():
    """Issue 48: an SE larger than the value is never "ok". For a figure whose truth may be 0
    (image lag, a charge-transfer trend) the data still bound it: value + 3 SE above, value - 3 SE
    below for a negative value."""
    from ares.analysis.stats.physical import resolved

    up = resolved(Estimate(0.016, 0.02, "%"), "image lag")
    assert up.bound == "upper" and up.value == pytest.approx(0.076) and "not resolved from 0" in up.note
    lo = resolved(Estimate(-5e-6, 2e-5, "1/px"), "signal change per row")
    assert lo.bound == "lower" and lo.value == pytest.approx(-6.5e-5) and up.verdict != "ok" != lo.verdict
    kept = Estimate(0.05, 0.02, "%")
    assert resolved(kept) is kept and resolved(Estimate.na("x")).verdict == "not available"


def test_resolved_takes_its_side_from_the_quantity_not_from_the_sign_of_the_value():
    """A quantity that cannot be below 0 (a variance, the max of a curve crossing 0) measured
    slightly negative is an upper limit value + 3 SE, not a lower limit; a max measured below 0
    by more than its SE is still not "ok" (it cannot be below 0); a signed figure keeps the
    two-sided meaning (the default)."""
    from ares.analysis.stats.physical import resolved

    up = resolved(Estimate(-0.1, 0.5, "DN^2"), "variance Ct", side="upper")
    assert up.bound == "upper" and up.value == pytest.approx(1.4) and up.verdict == "upper limit"
    signed = resolved(Estimate(-0.1, 0.5, "%"), "image lag")
    assert signed.bound == "lower" and signed.value == pytest.approx(-1.6)
    # a max 0.3 below 0 with SE 0.2: "ok" as a signed figure, not as a max (the data only bound it above)
    neg_max = Estimate(-0.3, 0.2, "%")
    assert resolved(neg_max) is neg_max
    assert resolved(neg_max, "LE_max", side="upper").bound == "upper"
    assert resolved(neg_max, "LE_max", side="upper").value == pytest.approx(0.3)
    low = resolved(Estimate(0.02, 0.05, "LSB"), "DNL min", side="lower")
    assert low.bound == "lower" and low.value == pytest.approx(-0.13)
    clear = Estimate(-0.4, 0.1, "LSB")
    assert resolved(clear, side="lower") is clear and resolved(Estimate(0.4, 0.1), side="upper").verdict == "ok"
    with pytest.raises(ValueError):
        resolved(clear, side="below")
