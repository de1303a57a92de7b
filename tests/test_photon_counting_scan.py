"""scans/photon_counting.xml on the simulator: K and read noise from the code histogram
against the simulator's truth, beside photon transfer, and the report page."""

from pathlib import Path

import pytest
from pdftext import pdf_text

from ares.protocol import load_scan
from ares.scan.runner import Runner
from ares.sim.params import SensorParams

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_photon_counting_scan_against_truth(tmp_path):
    scan = load_scan(ROOT / "scans" / "photon_counting.xml")
    p = SensorParams.from_dict(dict(scan.system.simulator.params))
    run = Runner(scan, out_dir=tmp_path / "run", frames=8).run()
    d = run.scan_results["photon_counting"]["stages"]["low_light"]
    K, rn = d["K"], d["read_noise_e"]
    assert K["verdict"] == "ok" and abs(K["value"] / p.gain_dn_per_e(1.0) - 1) < 0.005
    assert abs(K["value"] - p.gain_dn_per_e(1.0)) < 4 * K["se"]
    assert abs(rn["value"] / p.read_noise_e - 1) < 0.03 and abs(rn["value"] - p.read_noise_e) < 4 * rn["se"]
    assert d["photon_transfer"]["K"]["se"] > 2 * K["se"]  # the histogram does better at 0.3 e-
    assert "Photon-counting histogram" in pdf_text(tmp_path / "run" / "report.pdf")
