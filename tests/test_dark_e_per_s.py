"""Dark current in e-/s beside DN/s on a scan that measures no gain (the temperature scan):
"e-/s not available: the scan measures no gain; give --gain" on every surface until a gain is
given; ``ares report RUN --gain K`` records K in run.json and gives e-/s = (DN/s) / K on the
analyses, the report's temperature page and the key figures -- against the simulator's truth.
Before, those surfaces showed DN/s only."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from ares.cli import main

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "fixtures" / "xml" / "small" / "sim_small.xml"
NO_GAIN = "e-/s not available: the scan measures no gain; give --gain"
TEMPS = (45, 60, 75)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> tuple[Path, str]:
    d = tmp_path_factory.mktemp("temp")
    scan = d / "temperature.xml"
    scan.write_text(f"""<?xml version="1.0"?>
<scan name="temperature_small" version="1">
  <system href="{SMALL}"/>
  <settings><set quantity="analog_gain" value="1"/></settings>
  <frames>4</frames>
  <stages>
    <sweep name="dark_vs_t" scene="dark">
      <axis quantity="temperature"><values>{' '.join(map(str, TEMPS))}</values></axis>
      <axis quantity="exposure"><values>0.1 0.2 0.3 0.4 0.5 0.6</values></axis>
    </sweep>
  </stages>
  <analyses><analysis name="dark_current"/><analysis name="temperature"/></analyses>
  <output pdf="false"/>
</scan>
""")
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["run", str(scan), "--out", str(d / "run"), "--seed", "3"]) == 0
    return d / "run", out.getvalue()


def _analyses(d: Path) -> dict:
    return json.loads((d / "scan_results.json").read_text())["analyses"]


def _truth_e_per_s(d: Path, t: float) -> float:
    """The simulated sensor's mean dark current (e-/s) at temperature ``t``."""
    from ares.rig.factory import build_bench
    from ares.protocol import load_system
    from ares.scan.apply import apply_settings

    system = load_system(SMALL)
    bench = build_bench(system, seed=3)
    apply_settings(bench, system, {"temperature": t, "exposure": 0.5, "analog_gain": 1})
    s = bench.frames.settings()
    for k in ("test_mode", "streaming", "photon_flux"):
        s.pop(k)
    return float(bench.info["sensor"].truth(photon_flux=0.0, **s)["maps"]["dark_e_per_s"].mean())


def test_without_a_gain_every_surface_says_why_there_is_no_e_per_s(run_dir):
    d, terminal = run_dir
    a = _analyses(d)
    assert a["dark_current"]["gain_from"] == a["temperature"]["gain_from"] == NO_GAIN + ": ares report RUN --gain K"
    for v in a["dark_current"]["by_temperature"].values():
        assert v["rate_dn_per_s"]["value"] > 0 and v["rate_e_per_s"]["value"] is None
        assert v["rate_e_per_s"]["note"].startswith("the scan measures no gain; give --gain")
    assert a["temperature"]["rate_at_ref_dn_per_s"]["unit"] == "DN/s"
    assert a["temperature"]["rate_at_ref_e_per_s"]["value"] is None
    assert terminal.count("the scan measures no gain; give --gain") >= len(TEMPS) + 1  # each rate and the fit
    rows = [r for r in (d / "key_figures.csv").read_text().splitlines() if r.startswith("dark_current.by_temp")
            and ".rate_e_per_s," in r]
    assert len(rows) == len(TEMPS) and all("the scan measures no gain; give --gain" in r for r in rows)


def test_report_gain_gives_e_per_s_beside_dn_per_s(run_dir, tmp_path):
    from ares.sim.from_system import sim_params
    from ares.protocol import load_system

    d, _ = run_dir
    p = sim_params(load_system(SMALL))
    k = p.conversion_gain_uv_per_e / p.adc_lsb_uv  # the simulator's system gain at analog gain 1 (DN/e-)
    assert main(["report", str(d), "--gain", f"{k!r}DN/e-", "--csv", str(tmp_path)]) == 0
    meta = json.loads((d / "run.json").read_text())
    assert meta["gain_given"]["value"] == k and meta["gain_given"]["text"] == f"{k!r}DN/e-"
    assert main(["report", str(d), "--csv", str(tmp_path / "again")]) == 0  # the run's record still verifies
    a = _analyses(d)
    assert a["dark_current"]["gain_from"].startswith(f"given: {k!r}DN/e- (ares report --gain")
    for key, v in a["dark_current"]["by_temperature"].items():
        dn, e = v["rate_dn_per_s"], v["rate_e_per_s"]
        assert e["unit"] == "e-/s" and e["value"] == pytest.approx(dn["value"] / k, rel=1e-12)
        assert e["se"] == pytest.approx(dn["se"] / k, rel=1e-12)  # a given gain carries no SE of its own
        truth = _truth_e_per_s(d, v["temperature_c"])
        assert abs(e["value"] - truth) <= 4 * e["se"] + 0.02 * truth, (key, e, truth)
    ref = a["temperature"]
    assert ref["rate_at_ref_e_per_s"]["value"] == pytest.approx(ref["rate_at_ref_dn_per_s"]["value"] / k, rel=1e-12)
    kf = (tmp_path / "key_figures.csv").read_text()
    assert "e-/s" in kf and NO_GAIN not in kf

    from ares.report.scan_kinds import temperature_page
    from ares.report.source import read_run
    from ares.report.series_tables import dark_series

    run = read_run(d)
    fig = temperature_page(run, dark_series(run))
    page = " ".join(t.get_text() for t in fig.texts)
    assert "dark current (e-/s)" in page and f"gain for e-/s: given: {k!r}DN/e-" in page


def test_a_gain_declared_in_the_system_xml_gives_e_per_s_at_run_time(run_dir, tmp_path):
    """<sensor><gain dn_per_e se source>: a calibration's gain, its SE carried into the e-/s SEs."""
    from ares.protocol import load_system, save_system

    k, k_se = 0.21, 0.002
    text = SMALL.read_text().replace('<adc bits="12" channels="2" interleave="column"/>',
                                     '<adc bits="12" channels="2" interleave="column"/>\n'
                                     f'    <gain dn_per_e="{k}" se="{k_se}" source="PTC calibration 2026-03"/>')
    system = tmp_path / "sim_small_gain.xml"
    system.write_text(text)
    sy = load_system(system)
    assert (sy.sensor.gain_dn_per_e, sy.sensor.gain_se, sy.sensor.gain_source) == (k, k_se, "PTC calibration 2026-03")
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").sensor == sy.sensor
    d = tmp_path / "run"
    scan = run_dir[0] / "xml" / "temperature.xml"
    assert main(["run", str(scan), "--system", str(system), "--out", str(d), "--seed", "3", "-q"]) == 0
    a = _analyses(d)
    assert a["dark_current"]["gain_from"] == "system XML <gain>: 0.21 ± 0.002 DN/e- (PTC calibration 2026-03)"
    for v in a["dark_current"]["by_temperature"].values():
        dn, e = v["rate_dn_per_s"], v["rate_e_per_s"]
        assert e["value"] == pytest.approx(dn["value"] / k, rel=1e-12)
        assert e["se"] == pytest.approx(math.hypot(dn["se"] / k, e["value"] * k_se / k), rel=1e-12)
