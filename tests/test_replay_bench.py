"""Replay bench: recorded image data through the same scan path (Runner) as live hardware.

The EMVA 1288 reference data set (EMVA 1288 reference data set, (C) 2011 Basler AG,
CC BY-SA 3.0) is read from ``../shared/data`` (never copied into the project); the tests
that need it skip, saying why, when it is absent. The small synthetic data set built in
``tmp_path`` exercises the replay bench everywhere.

Which definitions give which number (also in ``ares/protocol/FORMAT.md``):

- ``emva1288`` (scan-level analysis) applies EMVA 1288 Release 3.0's definitions to the
  Runner's stage results: temporal variance *without* the frame-offset correction (rebuilt
  exactly from ARES's offset-corrected ``var_dn2`` plus the stage's frame means) and K
  from the origin fit up to 70 % of saturation. It reproduces the published values to
  ~1e-9 relative: K = 0.280769 DN/e-, sigma_y.dark = 3.07342 DN (intercept of the dark
  variance vs exposure), DSNU1288 = 0.5518 e-, PRNU1288 = 0.4327 %, u_I = 28.41 e-/s,
  saturation index 36 -- exactly what ``ares emva`` prints for the descriptor.
  Only the photon counts differ slightly: the scan knows light x exposure, not the
  descriptor's per-level counts (irradiance within 0.2 % of the scan's light level), so
  QE is 45.136 % vs 45.1356 % and mu_e.sat 13972.2 vs 13972.6 e-.
- ``ptc`` (ARES's own photon transfer) uses ARES's definitions: the offset-corrected
  (Release 4.0, unbiased for a drifting light) pair variance and a weighted line *with an
  intercept*. On this data set its K is 0.2828 DN/e- (+0.7 % vs the origin fit: the free
  intercept absorbs the small curvature of the CCD's PTC below 70 % of saturation) and
  its read noise sigma_y.dark 3.0731 DN (-0.01 %, the offset correction of the dark
  pairs) -- the same as the "ARES photon transfer" section of ``ares emva``.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ares.errors import InputError
from ares.rig.factory import build_bench
from ares.protocol import load_scan, load_system
from ares.scan.runner import Runner

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit"
DESCRIPTOR = DATA / "EMVA1288_Data.txt"
SYSTEM = ROOT / "protocols" / "emva_reference_ccd.xml"
SCAN = ROOT / "scans" / "emva_reference.xml"
ENV = "ARES_EMVA1288_REFERENCE"

need_data = pytest.mark.skipif(
    not DESCRIPTOR.is_file() and not os.environ.get(ENV),
    reason=f"EMVA 1288 reference data set not found at {DATA} (and ${ENV} not set); "
           "it is read from ../shared/data and never copied into the project")

PUBLISHED = {"K": 0.280769, "sigma_y_dark": 3.07342, "DSNU1288": 0.5518, "PRNU1288": 0.4327,
             "u_I_mean": 28.41, "u_e_sat": 13972.6, "QE": 45.14}


@pytest.fixture(scope="module")
def reference_run(shared_run):
    """`ares run scans/emva_reference.xml` (made once a session: test_report_kinds.py checks
    its report), read back from its run directory: the scan-level results and the stages."""
    out, rc, _ = shared_run("emva_reference", ["run", str(SCAN), "--seed", "2", "--quiet"])
    assert rc == 0
    assert json.loads((out / "run.json").read_text())["status"] == "done"
    stages = [json.loads(p.read_text()) for p in sorted((out / "stages").glob("*.json"))]
    return SimpleNamespace(scan_results=json.loads((out / "scan_results.json").read_text())["analyses"],
                           stages=stages)


@need_data
def test_emva_reference_scan_reproduces_published_values(reference_run):
    """The Runner on scans/emva_reference.xml: K within 0.5 % (in fact ~1e-9) of the
    published 0.280769 DN/e-, sigma_y.dark of 3.07342 DN (EMVA 1288 Release 3.0
    definitions, scan-level ``emva1288``); see the module docstring for ``ptc``'s."""
    r = reference_run.scan_results["emva1288"]
    assert abs(r["K"]["value"] / PUBLISHED["K"] - 1) < 0.005
    assert r["K"]["value"] == pytest.approx(PUBLISHED["K"], rel=2e-6)
    assert r["sigma_y_dark"]["value"] == pytest.approx(PUBLISHED["sigma_y_dark"], rel=2e-6)
    assert r["DSNU1288"]["value"] == pytest.approx(PUBLISHED["DSNU1288"], rel=2e-4)
    assert r["PRNU1288"]["value"] == pytest.approx(PUBLISHED["PRNU1288"], rel=2e-4)
    assert r["u_I_mean"]["value"] == pytest.approx(PUBLISHED["u_I_mean"], rel=2e-4)
    assert r["index_u_ysat"] == 36 and r["levels"] == 50
    # photons = light x exposure (the recorded irradiance is within 0.2 % of the light level)
    assert r["QE"]["value"] == pytest.approx(PUBLISHED["QE"], rel=2e-3)
    assert r["u_e_sat"]["value"] == pytest.approx(PUBLISHED["u_e_sat"], rel=2e-3)


@need_data
def test_emva_reference_scan_gives_the_descriptor_datasheet(reference_run):
    """The scan-level ``emva4`` analysis on the replayed stages gives the Release 4.0 set
    ``ares emva`` gives on the descriptor: photon-transfer figures to 1e-4 (photons are
    light x exposure here, the descriptor's counts there), spatial figures within their SE
    (the scan takes the row/column temporal noise from the stages' ANOVA components, the
    descriptor from the frames' row and column means)."""
    from ares.results.descriptor import analyse_descriptor

    scan = reference_run.scan_results["emva4"]["values"]
    desc = analyse_descriptor(DESCRIPTOR).sheet.values
    for k in ("K", "QE", "sigma_y_dark", "sigma_d", "mu_e_min", "mu_p_min", "mu_e_sat", "SNR_max", "DR",
              "mu_I_mean", "mu_I_var"):
        assert scan[k]["value"] == pytest.approx(desc[k].value, rel=1e-4), k
        assert scan[k]["verdict"] == desc[k].verdict, k
    for k in ("PRNU1288", "PRNU1288_col", "PRNU1288_row", "PRNU1288_pix", "DSNU1288_col", "LE"):
        assert abs(scan[k]["value"] - desc[k].value) < desc[k].se, k


@need_data
def test_emva_reference_scan_ares_ptc(reference_run):
    """ARES's own ``ptc`` on the same stages: the weighted line with intercept on the
    offset-corrected pair variance gives K 0.2828 (+0.7 %); the line's residuals fail
    (V/S falls ~6 % towards saturation), so the data prefer the Astier form (K 0.292,
    its low-signal slope): the brighter-fatter curvature is significant, so the straight
    line over the bent range is never the headline (issue 48) -- the Astier fit is, its
    errors the levels' measured scatter; sigma_y.dark 3.0731 DN."""
    p = reference_run.scan_results["ptc"]
    assert p["gain_line_dn_per_e"]["value"] == pytest.approx(PUBLISHED["K"], rel=0.015)
    assert p["gain_model"]["chosen"] == "astier" and p["gain_model"]["line_p"] < 1e-3
    assert p["gain_headline"]["estimator"] == "astier"
    assert p["gain_dn_per_e"]["value"] == p["gain_astier_dn_per_e"]["value"]
    assert p["gain_dn_per_e"]["value"] == pytest.approx(0.292, abs=0.002)
    assert p["read_noise_dn"]["value"] == pytest.approx(PUBLISHED["sigma_y_dark"], rel=1e-3)
    assert p["levels"] == 50  # the spatial stacks are separate stages, not PTC levels
    assert p["saturation_stage"] == "ptc[36]"
    assert p["saturation"]["last_unclipped_stage"] == "ptc[36]" and p["saturation"]["first_clipped_stage"] == "ptc[37]"


@need_data
def test_emva_reference_stages_are_the_recorded_levels(reference_run):
    stages = reference_run.stages
    ptc = [s for s in stages if s["group"] == "ptc"]
    assert len(ptc) == 50 and all(s["frames"] == 2 and s["dark_frames"] == 2 for s in ptc)
    assert ptc[0]["settings"]["exposure"] == pytest.approx(40e-6)
    sp = {s["name"]: s for s in stages if s["group"].startswith("spatial")}
    assert sp["spatial"]["frames"] == 50 and sp["spatial_dark"]["frames"] == 50


@need_data
def test_replay_bench_carries_the_attribution():
    bench = build_bench(load_system(SYSTEM))
    try:
        assert bench.info["attribution"] == "EMVA 1288 reference data set, (C) 2011 Basler AG, CC BY-SA 3.0"
        assert bench.frames.shape == (480, 640) and bench.frames.bit_depth == 12
    finally:
        bench.close()


# ------------------------------------------------------------------ errors

def _replay_system(tmp_path, descriptor: str, rows=480, cols=640, bits=12, name="sys.xml") -> Path:
    p = tmp_path / name
    p.write_text(f"""<?xml version="1.0" encoding="UTF-8"?>
<system name="replay_test" version="1">
  <sensor name="recorded">
    <array rows="{rows}" cols="{cols}"/>
    <cfa pattern="mono"/>
    <adc bits="{bits}"/>
  </sensor>
  <registers address_bits="8" value_bits="32">
    <field name="exposure" address="0x00" msb="31" scale="1e-9" unit="s" min="1e-9" max="4" default="1000"/>
  </registers>
  <controls exposure="exposure"/>
  <replay descriptor="{descriptor}" env="ARES_TEST_REPLAY_UNSET"/>
</system>
""")
    return p


def _scan(tmp_path, system: Path, body: str, frames: int = 2, name="scan.xml") -> Path:
    p = tmp_path / name
    p.write_text(f"""<?xml version="1.0" encoding="UTF-8"?>
<scan name="replay_test" version="1">
  <system href="{system}"/>
  <frames>{frames}</frames>
  <stages>
{body}
  </stages>
  <analyses><analysis name="ptc"/><analysis name="emva1288"/></analyses>
</scan>
""")
    return p


def test_missing_descriptor_is_one_sentence_with_file_and_line(tmp_path, monkeypatch):
    monkeypatch.delenv("ARES_TEST_REPLAY_UNSET", raising=False)
    sy = _replay_system(tmp_path, "no_such_folder/EMVA1288_Data.txt")
    system = load_system(sy)  # the XML itself is valid; the data are looked for when the bench is built
    with pytest.raises(InputError) as info:
        build_bench(system)
    msg = str(info.value)
    assert msg.startswith(f"{sy}:12: <replay> descriptor "), msg
    assert str(tmp_path / "no_such_folder" / "EMVA1288_Data.txt") in msg
    assert "\n" not in msg
    # the same sentence through the Runner (ares run)
    sc = _scan(tmp_path, sy, '<stage name="d" scene="dark"><set quantity="exposure" value="1e-6"/></stage>')
    with pytest.raises(InputError, match=r":12: <replay> descriptor .* not found"):
        Runner(load_scan(sc)).run()


def test_environment_override(tmp_path, monkeypatch):
    root = _synthetic_set(tmp_path / "data")
    sy = _replay_system(tmp_path, "not/here.txt", rows=6, cols=8)
    monkeypatch.setenv("ARES_TEST_REPLAY_UNSET", str(root))  # a folder: its EMVA1288_Data.txt
    system = load_system(sy)
    assert system.replay.path == root / "EMVA1288_Data.txt"
    build_bench(system).close()
    monkeypatch.setenv("ARES_TEST_REPLAY_UNSET", str(tmp_path / "elsewhere.txt"))
    with pytest.raises(InputError, match=r"not found \(from \$ARES_TEST_REPLAY_UNSET\)"):
        build_bench(load_system(sy))


@need_data
def test_too_many_frames_is_one_sentence(tmp_path):
    with pytest.raises(InputError) as info:
        Runner(load_scan(SCAN), frames=3).run()
    msg = str(info.value)
    assert "asks for 3 frames at exposure 4e-05 s" in msg and "only 2 were recorded" in msg, msg
    assert "EMVA1288_Data.txt:" in msg and "\n" not in msg


@need_data
def test_unrecorded_exposure_names_the_nearest(tmp_path):
    sc = _scan(tmp_path, SYSTEM, '<sweep name="p" scene="flat" dark="matched"><set quantity="light" value="3005400"/>'
                                 '<axis quantity="exposure"><values>0.005</values></axis></sweep>')
    with pytest.raises(InputError) as info:
        Runner(load_scan(sc)).run()
    msg = str(info.value)
    assert "no recording at exposure 0.005 s" in msg and "0.00488 s, 0.00516 s, 0.00518 s" in msg, msg


@need_data
def test_unrecorded_light_level_names_the_recorded_one(tmp_path):
    sc = _scan(tmp_path, SYSTEM, '<stage name="p" scene="flat"><set quantity="light" value="1e6"/>'
                                 '<set quantity="exposure" value="4e-5"/></stage>')
    with pytest.raises(InputError, match=r"no recording at light level 1e\+06 photons/pixel/s .* recorded there: "
                                         r"3e\+06 photons/pixel/s"):
        Runner(load_scan(sc)).run()


@need_data
def test_descriptor_contradicting_the_sensor(tmp_path):
    sy = _replay_system(tmp_path, str(DESCRIPTOR), rows=128, cols=128)
    with pytest.raises(InputError, match=r":12: <replay> descriptor .* records 640x480 12-bit images but <sensor> "
                                         r"declares 128x128 12-bit"):
        load_system(sy)


# ------------------------------------------------------------------ synthetic data (always runs)

def _synthetic_set(root: Path, K: float = 0.5, rows: int = 6, cols: int = 8) -> Path:
    """A tiny EMVA-style data set: 8 exposures, bright + dark pairs, Poisson electrons."""
    from PIL import Image

    root.mkdir(parents=True, exist_ok=True)
    (root / "images").mkdir(exist_ok=True)
    rng = np.random.default_rng(7)
    lines = ["# synthetic replay test set", "v 3.0", f"n 12 {cols} {rows}"]
    rate = 2e6  # photons/pixel/s
    for i, t_ns in enumerate(np.linspace(1e5, 8e5, 8)):
        photons = rate * t_ns * 1e-9
        for kind in ("b", "d"):
            lines.append(f"b {t_ns:.1f} {photons:.1f}" if kind == "b" else f"d {t_ns:.1f}")
            for j in (1, 2):
                e = rng.poisson(0.6 * photons, (rows, cols)) if kind == "b" else np.zeros((rows, cols))
                img = np.clip(np.round(100 + K * e + rng.normal(0, 2, (rows, cols))), 0, 4095).astype(np.uint16)
                name = f"{kind}_{i:03d}_{j}.png"
                Image.fromarray(img).save(root / "images" / name)
                lines.append(f"i images\\{name}")
    (root / "EMVA1288_Data.txt").write_text("\n".join(lines) + "\n")
    return root


def test_synthetic_replay_through_the_runner(tmp_path):
    root = _synthetic_set(tmp_path / "data", rows=24, cols=32)
    sy = _replay_system(tmp_path, "data/EMVA1288_Data.txt", rows=24, cols=32)
    values = " ".join(f"{t * 1e-9:.6g}" for t in np.linspace(1e5, 8e5, 8))
    sc = _scan(tmp_path, sy, f'<sweep name="ptc" scene="flat" dark="matched"><set quantity="light" value="2e6"/>'
                             f'<axis quantity="exposure"><values>{values}</values></axis></sweep>')
    out = Runner(load_scan(sc), out_dir=tmp_path / "run").run()
    assert out.status == "done" and len(out.stages) == 8
    r = out.scan_results["emva1288"]
    assert r["K"]["value"] == pytest.approx(0.5, rel=0.15)
    assert r["QE"]["value"] == pytest.approx(60, rel=0.15)
    assert "attribution" in r and "recorded data" in r["attribution"]  # not the Basler set
    assert math.isfinite(out.scan_results["ptc"]["gain_dn_per_e"]["value"])
    assert (root / "EMVA1288_Data.txt").is_file()


# ------------------------------------------------------------------ image-folder replay (<recording>)

def _folder_system(tmp_path, root: Path, rows: int, cols: int, exposures, name="folders.xml") -> Path:
    recs = []
    for i, t in enumerate(exposures):
        recs.append(f'    <recording exposure="{t:.6g}" light="2e6" images="{root.name}/b{i}"/>')
        recs.append(f'    <recording exposure="{t:.6g}" light="0" images="{root.name}/d{i}/*.tif"/>')
    p = tmp_path / name
    p.write_text(f"""<?xml version="1.0" encoding="UTF-8"?>
<system name="folder_replay" version="1">
  <sensor name="recorded">
    <array rows="{rows}" cols="{cols}"/>
    <cfa pattern="mono"/>
    <adc bits="12"/>
  </sensor>
  <registers address_bits="8" value_bits="32">
    <field name="exposure" address="0x00" msb="31" scale="1e-9" unit="s" min="1e-9" max="4" default="1000"/>
  </registers>
  <controls exposure="exposure"/>
  <replay>
{chr(10).join(recs)}
  </replay>
</system>
""")
    return p


def _folder_set(root: Path, exposures, rows: int, cols: int, frames: int = 4, K: float = 0.5) -> None:
    """Bright frames as PNG in folders b<i>/, dark frames as TIFF in d<i>/."""
    from PIL import Image

    rng = np.random.default_rng(3)
    for i, t in enumerate(exposures):
        for kind in ("b", "d"):
            (root / f"{kind}{i}").mkdir(parents=True, exist_ok=True)
            for j in range(frames):
                e = rng.poisson(0.6 * 2e6 * t, (rows, cols)) if kind == "b" else np.zeros((rows, cols))
                img = np.clip(np.round(100 + K * e + rng.normal(0, 2, (rows, cols))), 0, 4095).astype(np.uint16)
                Image.fromarray(img).save(root / f"{kind}{i}" / f"f{j:02d}.{'png' if kind == 'b' else 'tif'}")


def test_image_folder_replay_through_the_runner(tmp_path):
    exposures = [1e-4 * (i + 1) for i in range(6)]
    _folder_set(tmp_path / "rec", exposures, 24, 32)
    sy = _folder_system(tmp_path, tmp_path / "rec", 24, 32, exposures)
    system = load_system(sy)
    assert len(system.replay.recordings) == 12
    from ares.protocol import save_system

    save_system(system, tmp_path / "copy.xml")
    assert load_system(tmp_path / "copy.xml") == system
    values = " ".join(f"{t:.6g}" for t in exposures)
    sc = _scan(tmp_path, sy, f'<sweep name="ptc" scene="flat" dark="matched"><set quantity="light" value="2e6"/>'
                             f'<axis quantity="exposure"><values>{values}</values></axis></sweep>', frames=4)
    out = Runner(load_scan(sc)).run()
    assert out.status == "done" and all(s["frames"] == 4 and s["dark_frames"] == 4 for s in out.stages)
    assert out.scan_results["emva1288"]["K"]["value"] == pytest.approx(0.5, rel=0.15)
    with pytest.raises(InputError, match=r"asks for 5 frames .* only 4 were recorded \(.*folders.xml:\d+\)"):
        Runner(load_scan(sc), frames=5).run()


def test_image_folder_missing_is_one_sentence(tmp_path):
    sy = _folder_system(tmp_path, tmp_path / "nowhere", 24, 32, [1e-4])
    system = load_system(sy)
    with pytest.raises(InputError) as info:
        build_bench(system)
    msg = str(info.value)
    assert msg.startswith(f"{sy}:13: <recording images='nowhere/b0'>: "), msg
    assert str(tmp_path / "nowhere" / "b0") in msg and "not found" in msg
