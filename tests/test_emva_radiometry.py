"""Photon counts from what a lab measures (descriptor E=/P= levels, 4.0 Linear Eq. 3), the
refusal of an impossible quantum efficiency, and ``ares emva --missing``.

Truth: Eq. 3 against its lab-unit form Eq. 4 (50.34 photons per um^2 ms um uW/cm^2), and a
small data set drawn with a known quantum efficiency (Poisson electrons, gain 1 DN/e-)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ares.errors import InputError
from ares.hardware.emva_descriptor import photons_from_reading, read_descriptor

LAMBDA, AREA, DETECTOR_MM2 = 525.0, 20.25, 10.0  # nm, um^2 (4.5 um pixels), mm^2
QE_TRUE = 0.5
T_EXP = 1e-5  # s: 267 photons per 0.5 W/m^2


def test_eq3_against_eq4_lab_units():
    E, t = 0.37, 2.5e-3  # W/m^2, s
    mu_p = photons_from_reading("E", E, t, LAMBDA, AREA)
    eq4 = 50.34 * AREA * (t * 1e3) * (LAMBDA * 1e-3) * (E * 100)  # E in uW/cm^2: 1 W/m^2 = 100 uW/cm^2
    assert mu_p == pytest.approx(eq4, rel=2e-4)  # (Eq. 4's 50.34 is rounded to 4 digits)
    # a power meter's reading over its detector is the same irradiance
    P = E * DETECTOR_MM2 * 1e-6
    assert photons_from_reading("P", P, t, LAMBDA, AREA, DETECTOR_MM2) == pytest.approx(mu_p, rel=1e-12)


def _png(path, arr):
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(arr.astype(np.uint16)).save(path)


def make_radiometric_set(tmp_path, scale=1.0, kind="E", consts=True, levels=8, shape=(24, 32)):
    """Bright levels given as irradiance (or power) readings; the images drawn with QE_TRUE x
    the Eq. 3 photons (gain 1 DN/e-, offset 100 DN). ``scale`` multiplies the readings written
    to the file (a unit slip) but not the light the images saw."""
    rng = np.random.default_rng(5)
    lines = ["v 4.0", f"n 12 {shape[1]} {shape[0]}"]
    if consts:
        lines += [f"w {LAMBDA}", f"a {AREA}"] + ([f"m {DETECTOR_MM2}"] if kind == "P" else [])
    t = T_EXP
    for k in range(levels):
        E = 0.5 * (k + 1)  # W/m^2
        mu_p = photons_from_reading("E", E, t, LAMBDA, AREA)
        reading = E if kind == "E" else E * DETECTOR_MM2 * 1e-6
        lines.append(f"b {t * 1e9} {kind}={reading * scale!r}")
        for j in range(2):
            _png(tmp_path / "images" / f"b{k}_{j}.png", rng.poisson(QE_TRUE * mu_p, shape) + 100)
            lines.append(f"i images/b{k}_{j}.png")
    lines.append(f"d {t * 1e9}")
    for j in range(2):
        _png(tmp_path / "images" / f"d_{j}.png", rng.poisson(2, shape) + 100)
        lines.append(f"i images/d_{j}.png")
    p = tmp_path / "data.txt"
    p.write_text("\n".join(lines) + "\n")
    return p


@pytest.mark.parametrize("kind", ["E", "P"])
def test_levels_from_readings_give_the_true_qe(tmp_path, kind):
    from ares.analysis.kernels import jit
    from ares.results.descriptor import analyse_descriptor

    d = read_descriptor(make_radiometric_set(tmp_path, kind=kind))
    assert d.radiometry is not None and d.radiometry.wavelength_nm == LAMBDA
    expect = [photons_from_reading("E", 0.5 * (k + 1), T_EXP, LAMBDA, AREA) for k in range(8)]
    assert [lv.photons for lv in d.temporal_bright] == pytest.approx(expect, rel=1e-12)
    with jit.avoided():
        an = analyse_descriptor(d)
    qe = an.sheet.values["QE"]
    assert qe.value == pytest.approx(100 * QE_TRUE, abs=max(4 * qe.se, 1.0))


def test_a_unit_slip_that_makes_qe_impossible_is_refused_with_the_numbers(tmp_path):
    from ares.analysis.kernels import jit
    from ares.results.descriptor import analyse_descriptor

    d = read_descriptor(make_radiometric_set(tmp_path, scale=0.01))  # readings 100x too small: QE ~ 5000 %
    with jit.avoided(), pytest.raises(InputError) as exc:
        analyse_descriptor(d)
    msg = str(exc.value)
    assert "outside 0 - 100 %" in msg and "W/m^2" in msg and f"{LAMBDA:g} nm" in msg and "Eq. 3" in msg
    assert "data.txt:" in msg  # the file and line of the level


def test_constants_from_the_command_line_and_missing_ones(tmp_path):
    p = make_radiometric_set(tmp_path, consts=False)
    with pytest.raises(InputError, match=r"data.txt:\d+: .*wavelength .*--wavelength-nm"):
        read_descriptor(p)
    d = read_descriptor(p, wavelength_nm=LAMBDA, pixel_area_um2=AREA)
    assert d.temporal_bright[0].photons == pytest.approx(photons_from_reading("E", 0.5, T_EXP, LAMBDA, AREA))
    q = make_radiometric_set(tmp_path / "p", kind="P", consts=False)
    with pytest.raises(InputError, match="detector area"):
        read_descriptor(q, wavelength_nm=LAMBDA, pixel_area_um2=AREA)
    bad = tmp_path / "bad.txt"
    bad.write_text(p.read_text().replace("b 10000.0 E=", "b 10000.0 X=", 1))
    with pytest.raises(InputError, match="PHOTONS, E=IRRADIANCE"):
        read_descriptor(bad, wavelength_nm=LAMBDA, pixel_area_um2=AREA)


def test_missing_report(tmp_path, capsys):
    """One exposure time, 8 steps, no stacks: what each release lacks, from the descriptor alone."""
    from ares.cli import main
    from ares.results.emva_missing import coverage

    p = make_radiometric_set(tmp_path)
    covs = {c.release: c for c in coverage(read_descriptor(p, check_files=False))}
    lin = covs["4.0 Linear"]
    assert "K" in lin.supported and "QE" in lin.supported and "mu_e_min_area" in lin.supported
    missing = dict(lin.missing)
    assert "6" in missing["mu_I_mean, mu_I_var"] and "Section 7.1" in missing["mu_I_mean, mu_I_var"]
    assert any("stack" in why for figs, why in lin.missing if figs.startswith("DSNU1288"))
    assert any("42 more photon-transfer steps" in why for _, why in lin.missing)
    assert "u_I_mean" not in covs["3.0 / 3.1"].supported
    assert ("QE, K, 1/K" in dict(covs["4.0 General"].missing))
    assert main(["emva", str(p), "--missing"]) == 0
    out = capsys.readouterr().out
    assert "Release 4.0 Linear" in out and "missing mu_I_mean, mu_I_var" in out


def test_the_descriptors_pixel_area_gives_the_per_area_figures(tmp_path, capsys):
    """An 'a' record is the pixel area of the per-area figures (as --pixel-size-um would be)."""
    from ares.cli import main
    from ares.report.emva_xml import read_xml

    p = make_radiometric_set(tmp_path)
    out = tmp_path / "r.xml"
    assert main(["emva", str(p), "--release", "3.1", "--xml", str(out)]) == 0
    s = read_xml(out)["sensitivity"]
    for k in ("u_p_min", "u_e_min", "u_p_sat", "u_e_sat"):
        assert s[k + "_area"]["value"] == pytest.approx(s[k]["value"] / AREA, rel=1e-12)
    capsys.readouterr()
