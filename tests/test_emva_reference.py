"""EMVA 1288 reference CCD: reproduce the published Release 3.0 results.

Data: EMVA 1288 reference data set, (C) 2011 Basler AG, CC BY-SA 3.0 -- read from
../shared/data/ (never copied into the project); the tests skip, saying why, without it.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ares.analysis.emva.release3 import ATTRIBUTION

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit"
DESC = DATA / "EMVA1288_Data.txt"

pytestmark = pytest.mark.skipif(
    not DESC.is_file(),
    reason=f"EMVA 1288 reference data set not found at {DATA} (it is not shipped with ARES)",
)

PUBLISHED = {  # value, relative tolerance
    "K": (0.280769, 0.005),
    "sigma_y_dark": (3.07342, 0.005),
    "u_e_sat": (13972.6, 0.02),
    "QE": (45.14, 0.01),
    "DSNU1288": (0.5518, 0.03),
    "PRNU1288": (0.4327, 0.03),
    "u_I_mean": (28.41, 0.02),
}


@pytest.fixture(scope="module")
def analysis():
    from ares.results.descriptor import analyse_descriptor

    return analyse_descriptor(DESC)  # loads the 300 PNGs once


@pytest.mark.parametrize("name", sorted(PUBLISHED))
def test_published_value(analysis, name):
    value, tol = PUBLISHED[name]
    got = analysis.emva.values[name]
    assert got.value == pytest.approx(value, rel=tol), f"{name}: {got} vs published {value} ({ATTRIBUTION})"


def test_exact_reproduction_of_release_3_definitions(analysis):
    """The Release 3.0 definitions reproduce the published numbers to their printed digits."""
    v = analysis.emva.values
    assert v["K"].value == pytest.approx(0.280769, abs=5e-7)
    assert v["sigma_y_dark"].value == pytest.approx(3.07342, abs=5e-6)
    assert v["u_e_sat"].value == pytest.approx(13972.6, abs=0.05)
    assert v["QE"].value == pytest.approx(45.14, abs=0.005)
    assert v["DSNU1288"].value == pytest.approx(0.5518, abs=5e-5)
    assert v["PRNU1288"].value == pytest.approx(0.4327, abs=5e-5)
    assert v["u_I_mean"].value == pytest.approx(28.41, abs=0.005)


def test_saturation_index(analysis):
    assert analysis.emva.index_u_ysat == 36
    assert analysis.ptc.saturation_index == 36


def test_alternative_definitions_differ(analysis):
    """mu_e.sat as dark-subtracted signal / K is ~0.8 % below QE*mu_p.sat; the Release 4.0
    pair variance (mean-difference term) moves K by ~0.25 %: both are reported, labelled."""
    alt = analysis.emva.extra["u_e_sat_signal"].value
    assert alt == pytest.approx(13858.0, rel=0.002)
    assert analysis.ptc.gain_origin_dn_per_e.value == pytest.approx(0.28006, rel=0.001)


def test_ptc_excludes_clipped_levels_with_reason(analysis):
    ex = dict(analysis.ptc.excluded())
    assert set(range(37, 50)) <= set(ex)
    assert all("clipped" in ex[i] for i in range(37, 50))
    assert all(lv.status != "excluded" for lv in analysis.ptc.levels[:37])
    fit = analysis.ptc.used("fit")
    assert max(lv.index for lv in fit) == analysis.emva.index_sensitivity_max == 25


def test_ares_ptc_numbers_are_consistent(analysis):
    p = analysis.ptc
    # the line's residuals fail on this CCD (V/S falls ~6 % from the dimmest to the last
    # unclipped level): the brighter-fatter curvature is significant, so the straight line
    # over the bent range is never the headline (issue 48): the Astier fit is, its errors
    # the levels' measured scatter (2x the counts'), against which it passes its residual
    # check. Its K is the zero-signal slope (V/S of the dimmest level, below); the
    # published Release 3.0 K (origin fit, 0-70 %) stays within 0.5 % as its own figure
    assert p.gain_model.chosen == "astier" and p.gain_model.astier_p > 1e-3
    assert p.gain_model.line_p < 1e-3
    assert p.errors.source == "measured" and 1.5 < p.errors.scatter.ratio < 3
    head = p.gain_headline()
    assert head["estimator"] == "astier" and "curvature term is significant" in head["reason"]
    assert p.gain_dn_per_e.value == p.gain_astier_dn_per_e.value
    assert p.gain_dn_per_e.value != p.gain_wls_dn_per_e.value
    assert p.gain_origin_dn_per_e.value == pytest.approx(PUBLISHED["K"][0], rel=0.005)
    low = p.levels[1]
    assert p.gain_astier_dn_per_e.value == pytest.approx(low.variance / low.signal, rel=0.01)
    assert p.linearity_check.holds is False and "Eq. 51" in p.linearity_check.note
    # saturation bracket: between the last unclipped level (36) and the first clipped (37)
    assert (p.saturation.last_ok, p.saturation.first_clipped) == (36, 37)
    assert p.read_noise_e.value == pytest.approx(3.0734 / p.gain_dn_per_e.value, rel=0.02)
    assert p.full_well_e["max_variance"].available
    for k, e in p.full_well_e.items():
        assert e.note, k


def test_cli_json_and_table(analysis, capsys, tmp_path):
    from ares.cli import main

    assert main(["emva", str(DESC), "--release", "3.0", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    out = doc["values"]  # the shape of every release: {"release", "values", ...}
    assert doc["release"] == "EMVA 1288 Release 3.0" and doc["index_u_ysat"] == 36
    for k in ("K", "sigma_y_dark", "u_e_sat", "QE", "SNR_max", "DR", "u_I_mean", "DSNU1288", "PRNU1288",
              "LE_min", "LE_max"):
        assert "value" in out[k] and "unit" in out[k]
    assert out["K"]["value"] == pytest.approx(0.280769, rel=1e-5)
    assert doc["attribution"] == ATTRIBUTION
    pdf = tmp_path / "r.pdf"
    assert main(["emva", str(DESC), "--release", "3.0", "--pdf", str(pdf)]) == 0
    text = capsys.readouterr().out
    assert ATTRIBUTION in text and "PRNU1288" in text
    assert pdf.read_bytes()[:4] == b"%PDF"


def _close(a, b, path=""):
    """Every number of two JSON-like results equal within float64 rounding (1e-12 relative)."""
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for k in a:
            _close(a[k], b[k], f"{path}/{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _close(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-300, nan_ok=True), path
    else:
        assert a == b, path


def test_the_command_runs_without_numba_and_gives_the_kernels_figures(analysis):
    """``ares emva`` takes the numpy paths (numba's import and first load cost what its
    kernels save on one data set): every figure of every release equals the kernels'
    within float64 rounding, and the command's process never imports numba."""
    pytest.importorskip("numba")
    import subprocess
    import sys

    import ares.analysis.kernels.pair as pk
    from ares.analysis.kernels import jit
    from ares.results.descriptor import analyse_descriptor

    assert pk._kernel_c is not None  # the fixture's analysis ran the kernels (the pairs' pass; the
    # high-pass of the exact integer sums never needs the float low-pass kernel)
    with jit.avoided():
        plain = analyse_descriptor(DESC)
    _close(analysis.emva.to_json(), plain.emva.to_json())
    _close(analysis.sheet.to_json(), plain.sheet.to_json())
    _close(analysis.general.to_json(), plain.general.to_json())
    _close({k: e.to_dict() for k, e in analysis.release31.items()}, {k: e.to_dict() for k, e in plain.release31.items()})
    code = ("import sys\nfrom ares.cli import main\nrc = main(['emva', sys.argv[1]])\n"
            "print([m for m in ('numba', 'numpy.ma', 'scipy') if m in sys.modules])\nsys.exit(rc)")
    r = subprocess.run([sys.executable, "-c", code, str(DESC)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "[]"  # numba's load, numpy.ma's and scipy's imports cost more than they save


def test_every_release_3_figure_comes_with_its_se_or_its_reason(analysis):
    """Release 3.0's PRNU1288 and LE_min/LE_max were "ok" with no SE (a bare number); each now has
    its SE (the spatial variance's sampling; the extreme level's mean's temporal noise) or a
    verdict that says why not (issue 48)."""
    import math

    for k, e in (list(analysis.emva.values.items()) + [(f"3.1 {k}", e) for k, e in (analysis.release31 or {}).items()]
                 + [(f"extra {k}", e) for k, e in analysis.emva.extra.items()]):  # (the extras: the 3.x XML's names)
        if e.verdict == "ok":
            assert math.isfinite(e.se) and (e.se > 0 or e.is_exact), (k, e)
    # DSNU1288 in DN: the dark spatial std with its own SE (no K in it), the e- figure x K in value
    dn, e_ = analysis.emva.extra["DSNU1288_DN"], analysis.emva.values["DSNU1288"]
    K = analysis.emva.values["K"].value
    assert dn.value == pytest.approx(e_.value * K, rel=1e-12) and dn.se < e_.se * K
    assert analysis.release31["PRNU1288"].verdict == "ok"  # (Release 3.1's high-passed figures too)
    le = analysis.emva.values["LE_min"]
    assert le.se < 0.05 * abs(le.value)  # (300 000 pixels: the level means are known to ~1e-5)


def test_release_3_dark_noise_at_one_exposure_has_its_se():
    """With one exposure time (the light varied) sigma_y.dark is the first dark pair's variance,
    no intercept: its SE is that variance's own, sqrt(2 / n) s2 for n pixels -- it was NaN and
    shown "ok". Truth: the closed form. Below the quantization floor: only limits."""
    import math

    import numpy as np

    from ares.analysis.emva.release3 import TemporalData, emva1288_results

    n, u_p = 4096, np.linspace(100, 40000, 30)
    y = 0.3 * 0.5 * u_p
    var = 0.3 * y + 9.0
    var[-3:] = var[-4] * np.array([0.6, 0.2, 0.05])
    td = TemporalData(np.full(30, 0.01), u_p, 100 + y, var, np.full(30, 100.0), np.full(30, 9.0), n)
    e = emva1288_results(td).values["sigma_y_dark"]
    assert e.verdict == "ok" and e.value == 3.0
    assert e.se == pytest.approx(9.0 * math.sqrt(2 / n) / (2 * 3.0), rel=1e-12)
    # a quantization-limited dark (0.1 DN^2 < 0.24): the floor sqrt(0.24) is only an upper limit, and
    # so are the figures read off it (mu_p.min, mu_e.min, sigma_d below; DR above) -- the value as the
    # reference writes it (0.4899 DN), never "ok" with the floor's SE
    import dataclasses

    r = emva1288_results(dataclasses.replace(td, s2_ydark=np.full(30, 0.1)))
    v, x = r.values, r.extra
    assert v["sigma_y_dark"].bound == "upper" and v["sigma_y_dark"].value == pytest.approx(math.sqrt(0.24))
    assert v["DR"].bound == "lower" and x["DR_dB"].bound == "lower"
    assert x["u_p_min"].bound == x["u_e_min"].bound == x["sigma_d"].bound == "upper"
    assert x["u_e_min"].value == pytest.approx(math.sqrt(0.24) / v["K"].value + 0.5, rel=1e-12)


def test_a_linearity_extreme_not_resolved_from_0_is_only_a_limit():
    """A perfectly linear sensor on few pixels: the extremes' deviations are noise, their SE larger
    than themselves -- a limit, never "ok"."""
    import numpy as np

    from ares.analysis.emva.release3 import TemporalData, emva1288_results

    rng = np.random.default_rng(48)
    t = np.linspace(0.001, 0.05, 40)
    u_p = 2e5 * t
    y = 0.3 * 0.5 * u_p  # K 0.3 DN/e-, QE 50 %
    var = 0.3 * y + 9.0
    var[-3:] = var[-4] * np.array([0.6, 0.2, 0.05])  # saturation
    npx = 16
    u_y = 100 + y + rng.normal(0, np.sqrt(var / (2 * npx)))
    td = TemporalData(t, u_p, u_y, var, np.full(t.size, 100.0), np.full(t.size, 9.0), npx)
    v = emva1288_results(td).values
    for k in ("LE_min", "LE_max"):
        assert v[k].verdict != "ok" or v[k].se < abs(v[k].value), (k, v[k])
    assert any(v[k].bound for k in ("LE_min", "LE_max")), (v["LE_min"], v["LE_max"])
