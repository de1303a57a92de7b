"""Spectral QE (EMVA 1288 4.0 Linear, Section 9) on the simulated spectral bench: QE(lambda)
against the simulator's curve, its uncertainty covering the error, the verdicts (outside
the calibration table, saturated, too dark), the same figures in JSON/CSV/HDF5, and
one-line errors for a malformed calibration table."""

import csv
import math
import shutil
from pathlib import Path

import h5py
import pytest

from ares.cli import main
from ares.errors import InputError, ValueOutOfRange
from ares.protocol import load_scan, load_system
from ares.protocol.calibration import parse_calibration
from ares.scan.runner import Runner
from ares.sim.params import SensorParams

ROOT = Path(__file__).resolve().parents[1]

SCAN = """<?xml version="1.0" encoding="UTF-8"?>
<scan name="spectral_small" version="1">
  <system href="sim_spectral.xml"/>
  <settings><set quantity="exposure" value="0.01"/><set quantity="analog_gain" value="1"/></settings>
  <frames>6</frames>
  <stages>
    <sweep name="ptc" scene="flat" dark="matched"><set quantity="wavelength" value="550"/>
      <axis quantity="light"><log start="20000" stop="1400000" points="6"/></axis></sweep>
    <sweep name="spectral" scene="flat" dark="matched"><set quantity="light" value="1000000"/>
      <axis quantity="wavelength"><values>425 775 950 1050</values></axis></sweep>
    <sweep name="bright" scene="flat" dark="matched" frames="2"><set quantity="light" value="100000000"/>
      <axis quantity="wavelength"><values>500 600</values></axis></sweep>
    <sweep name="dim" scene="flat" dark="matched" frames="2"><set quantity="light" value="300"/>
      <axis quantity="wavelength"><values>500 600</values></axis></sweep>
  </stages>
  <analyses><analysis name="spectral_qe"/></analyses>
  <output pdf="false"/>
</scan>
"""


def _bench_dir(tmp_path: Path) -> Path:
    for name in ("sim_spectral.xml", "sim_spectral_pd.csv"):
        shutil.copy(ROOT / "protocols" / name, tmp_path / name)
    return tmp_path


@pytest.mark.slow
def test_qe_against_the_simulator_truth(tmp_path):
    d = _bench_dir(tmp_path)
    (d / "scan.xml").write_text(SCAN)
    scan = load_scan(d / "scan.xml")
    truth = SensorParams.from_dict(dict(scan.system.simulator.params))
    out = tmp_path / "run"
    run = Runner(scan, out_dir=out, seed=3).run()
    res = run.scan_results["spectral_qe"]
    K = res["gain_dn_per_e"]
    assert K["verdict"] == "ok" and abs(K["value"] / truth.gain_dn_per_e(1.0) - 1) < 4 * K["se"] / K["value"]
    pts = res["points"]
    for key in ("425nm", "775nm", "950nm"):
        q, nm = pts[key]["qe"], pts[key]["wavelength_nm"]
        err = q["value"] - 100 * truth.qe_at(nm)
        assert q["verdict"] == "ok" and abs(err) < 1.0, (key, q, err)  # 1 % absolute
        assert abs(err) <= 2 * q["se"], (key, q, err)  # the propagated uncertainty covers the error
        b = pts[key]["budget"]
        assert q["se"] / q["value"] == pytest.approx(math.sqrt(sum(v * v for v in b.values())), rel=1e-9)
    # the calibration's share: u(R) / R, both linear between the table's 400 and 450 nm rows
    assert pts["425nm"]["budget"]["u_calibration"] == pytest.approx((0.0027 + 0.0024) / (0.18 + 0.24), rel=1e-9)
    from ares.protocol.quantities import PRODUCES
    from ares.results.registry import flatten

    assert {k.split(".")[-1] for k in flatten(res)} <= PRODUCES["spectral_qe"]  # what a limit may name
    assert pts["1050nm"]["qe"]["verdict"] == "not available"
    assert pts["1050nm"]["qe"]["note"] == "outside the photodiode's calibration table (350-1000 nm)"
    # the bright and dim sweeps: saturated and too dark, said so (they are spectral points too)
    assert pts["500nm"]["qe"]["note"].startswith("saturated (") and pts["600nm_dim"]["qe"]["note"].startswith("too dark (")
    assert pts["500nm"]["stage"] == "bright[0]" and pts["600nm_dim"]["stage"] == "dim[1]"
    by_stage = {p["stage"]: p for p in _csv(out / "spectral_qe.csv")}
    assert by_stage["bright[0]"]["verdict"].startswith("saturated")
    assert by_stage["dim[1]"]["verdict"].startswith("too dark")
    # one truth: JSON, CSV and HDF5 carry the same numbers, with units in the column names
    with h5py.File(out / "report.h5") as f:
        g = f["spectral_qe"]
        assert g["qe_pct"].attrs["unit"] == "%" and g["wavelength_nm"].attrs["unit"] == "nm"
        assert g["mu_p_photons"].attrs["unit"] == "photons"
        h5 = dict(zip([s.decode() if isinstance(s, bytes) else s for s in g["stage"][()]], g["qe_pct"][()]))
    for p in pts.values():
        if p["qe"]["value"] is not None and p["stage"] in by_stage:
            assert float(by_stage[p["stage"]]["qe_pct"]) == p["qe"]["value"] == h5[p["stage"]]


def _csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


GOOD = "wavelength_nm,responsivity_a_per_w,u_responsivity_a_per_w\n400,0.2,0.002\n500,0.3,0.003\n"


@pytest.mark.parametrize("text,line,words", [
    ("wavelength,resp\n400,0.2\n", 1, "the header must be"),
    (GOOD + "450,0.25,0.002\n", 4, "does not follow 500 nm"),
    (GOOD + "600,-0.1,0.002\n", 4, "must be above 0"),
    (GOOD + "600,0.3,-1\n", 4, "must not be negative"),
    (GOOD + "600,abc,0.1\n", 4, "not a number"),
    (GOOD + "600,0.3\n", 4, "expected 3 fields"),
    (GOOD + "600,nan,0.1\n", 4, "finite"),
    ("# only a comment\nwavelength_nm,responsivity_a_per_w,u_responsivity_a_per_w\n400,0.2,0.01\n", 2,
     "at least 2 wavelengths"),
])
def test_malformed_calibration_is_one_line_naming_file_and_line(text, line, words):
    with pytest.raises(InputError) as e:
        parse_calibration(text, "pd.csv")
    msg = str(e.value)
    assert msg.startswith(f"pd.csv:{line}: ") and words in msg and "\n" not in msg


def test_bad_calibration_through_the_system_file(tmp_path, capsys):
    d = _bench_dir(tmp_path)
    (d / "sim_spectral_pd.csv").write_text(GOOD + "450,0.25,0.002\n")
    assert main(["validate", str(d / "sim_spectral.xml")]) == 2
    err = capsys.readouterr()
    text = (err.out + err.err).strip()
    assert "sim_spectral_pd.csv:4: wavelength 450 nm does not follow 500 nm" in text and "Traceback" not in text
    (d / "sim_spectral_pd.csv").unlink()
    with pytest.raises(InputError, match=r"sim_spectral.xml:\d+: <photodiode calibration='sim_spectral_pd.csv'>: .* not found"):
        load_system(d / "sim_spectral.xml")


def test_wavelength_outside_the_monochromator_is_refused(tmp_path):
    d = _bench_dir(tmp_path)
    (d / "scan.xml").write_text(SCAN.replace("<values>425 775", "<values>1200 775"))
    with pytest.raises(InputError, match=r"scan.xml:\d+: wavelength 1200 nm is outside the monochromator's range 250 .. 1100 nm"):
        load_scan(d / "scan.xml")


def test_emulated_instruments_speak_their_dialects():
    from ares.rig.factory import build_bench

    bench = build_bench(load_system(ROOT / "protocols" / "sim_spectral.xml"))
    try:
        m, pd = bench.monochromator, bench.photodiode
        t0 = bench.clock.now()
        m.set_wavelength(632.8)  # answered at once: the grating has not moved yet (the drive's position)
        assert m.get_wavelength() == 550.0
        m.settle()  # *OPC?: answered when the move is done, on the bench's clock
        assert m.get_wavelength() == 632.8 and m.bandwidth() == 5.0
        assert m.port.instrument.log[-5:] == ["GOWAVE 632.80", "WAVE?", "*OPC?", "WAVE?", "BANDPASS?"]
        assert 0.5 < bench.clock.now() - t0 < 1.5  # 82.8 nm at 150 nm/s, with acceleration and ringing
        with pytest.raises(ValueOutOfRange):
            m.set_wavelength(1500)
        bench.light.set_level(1e6)
        i = pd.read()
        assert pd.port.instrument.log[-1] == "MEAS:CURR?"
        sim = pd.port.instrument.device  # the simulated diode: I = R(lambda) P + dark, 0.1 % noise
        r = 0.38 + (632.8 - 600) / 50 * (0.42 - 0.38)  # the table, linear between 600 and 650 nm
        assert i == pytest.approx(r * sim.power_w() + 2e-11, rel=0.005)
    finally:
        bench.close()


def test_qe_point_is_eq_82_with_eq_3_and_its_budget():
    """Closed form: 1 uW on a 1 cm^2 diode at 500 nm, 3.3 um pixels, 10 ms -> mu_p by Eq. (3)."""
    from ares.analysis.stats.estimate import Estimate
    from ares.analysis.optics.spectral_qe import C_LIGHT, H_PLANCK, SpectralPoint, qe_point

    table = ((400.0, 600.0), (0.2, 0.4), (0.002, 0.004))  # R(500) = 0.3 A/W, u = 0.003
    mu_p = (3.3e-6) ** 2 * (1e-6 / 1e-4) * 0.01 * 500e-9 / (H_PLANCK * C_LIGHT)
    K = Estimate(0.25, 0.0025, "DN/e-")
    net = 0.25 * 0.6 * mu_p  # QE 60 %
    p = SpectralPoint(500.0, 5.0, 0.01, 64 + net, 0.1, 64.0, 0.1, 1.0, 0.0, 0.25 * net + 1.0,
                      0.3e-6 + 1e-11, 3e-10, 1e-11, 3e-10)
    r = qe_point(p, K, table, 1e-4, (3.3e-6) ** 2)
    assert r["mu_p"].value == pytest.approx(mu_p, rel=1e-12) and r["qe"].value == pytest.approx(60.0, rel=1e-12)
    b = r["budget"]
    assert b["u_calibration"] == pytest.approx(0.01) and b["u_gain"] == pytest.approx(0.01)
    assert b["u_photodiode"] == pytest.approx(math.hypot(3e-10, 3e-10) / 0.3e-6)
    # a power meter's reading is the power itself: the same QE
    pw = SpectralPoint(*[getattr(p, f) for f in ("wavelength_nm", "bandwidth_nm", "exposure_s", "mean_dn",
                                                 "mean_se_dn", "dark_dn", "dark_se_dn", "dark_sigma_dn",
                                                 "frac_at_max", "var_dn2")], 1e-6, 1e-9, 0.0, 0.0)
    assert qe_point(pw, K, table, 1e-4, (3.3e-6) ** 2, "power")["qe"].value == pytest.approx(60.0, rel=1e-12)


def test_a_silent_photodiode_meter_is_one_sentence(tmp_path):
    from ares.errors import HardwareError
    from ares.rig.factory import build_bench

    bench = build_bench(load_system(ROOT / "protocols" / "sim_spectral.xml"))
    try:
        bench.photodiode.port.instrument.faults = {"timeout_at": bench.photodiode.port.instrument.commands}
        with pytest.raises(HardwareError) as e:
            bench.photodiode.read()
        assert str(e.value) == "pd on aresemu://pm100: no reply to 'MEAS:CURR?' within 2 s (timeout: the instrument " \
                               "is silent, its port open)"
    finally:
        bench.close()


def test_power_meter_reading(tmp_path):
    from ares.rig.factory import build_bench

    d = _bench_dir(tmp_path)
    x = (d / "sim_spectral.xml").read_text()
    (d / "sim_spectral.xml").write_text(x.replace('reading="current"', 'reading="power"').replace(
        '<command name="read" send="MEAS:CURR?"', '<command name="wavelength" send="SENS:CORR:WAV {value:.1f};*OPC?" '
        'reply="1"/>\n        <command name="read" send="MEAS:POW?"'))
    sy = load_system(d / "sim_spectral.xml")
    bench = build_bench(sy)
    try:
        from ares.scan.apply import apply_settings

        apply_settings(bench, sy, {"wavelength": 800.0, "light": 1e6})
        assert bench.photodiode.port.instrument.log[-1] == "SENS:CORR:WAV 800.0;*OPC?"  # told the wavelength
        w = bench.photodiode.read()
        assert bench.photodiode.port.instrument.log[-1] == "MEAS:POW?"
        assert w == pytest.approx(bench.photodiode.port.instrument.device.power_w(), rel=0.005)
    finally:
        bench.close()
