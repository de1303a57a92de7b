"""Protocol layer: shipped XML validates, round-trips, and every broken file gives one clear sentence."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from ares.cli import main
from ares.commands.validate import validate_one
from ares.errors import InputError
from ares.protocol import load_scan, load_system, save_scan, save_system, validate_file
from ares.sim.regmap import SIM_REGISTER_MAP

ROOT = Path(__file__).resolve().parents[1]
SCANS = sorted((ROOT / "scans").glob("*.xml"))
SYSTEMS = sorted((ROOT / "protocols").glob("*.xml"))
BROKEN = ROOT / "fixtures" / "xml" / "broken"

# file -> (line, fragment of the one-sentence message)
EXPECTED = {
    "bad_scene.xml": (6, "<stage scene=...> must be one of dark, flat, got 'sunny'"),
    "duplicate_stage_name.xml": (7, "repeats the name 'd'"),
    "empty.xml": (1, "file is empty"),
    "entity_billion_laughs.xml": (2, "<!DOCTYPE> declarations are not allowed"),
    "exposure_out_of_range.xml": (5, "'exposure': 500 s is above its maximum 100"),
    "field_out_of_range.xml": (5, "'sf_bias': 4 V is above its maximum 3.3"),
    "frames_not_integer.xml": (4, "<frames> must be an integer >= 2, got 'ten'"),
    "frames_too_few.xml": (4, "<frames> must be >= 2, got '1'"),
    "limit_min_above_max.xml": (9, "min 5 is above max 1"),
    "limit_without_bounds.xml": (9, "needs min= or max="),
    "matched_dark_on_dark.xml": (6, "dark='matched' only applies to a flat scene"),
    "mismatched_tag.xml": (7, "not well-formed XML"),
    "missing_attribute.xml": (6, "<stage> needs attribute 'name'"),
    "missing_frames.xml": (5, "<stages> is not allowed here (expected <settings> or <frames>)"),
    "missing_stages.xml": (2, "<scan> is missing <stages>"),
    "missing_system.xml": (3, "expected <description> or <system>"),
    "namespaced_root.xml": (2, "root element must be <scan> or <system>"),
    "negative_light.xml": (5, "light level must be >= 0"),
    "not_xml.xml": (1, "not well-formed XML"),
    "output_bad_boolean.xml": (8, "<output raw_frames=...> must be true or false, got 'maybe'"),
    "readonly_field.xml": (5, "'chip_id' is read-only"),
    "region_outside_array.xml": (9, "does not fit in the 640x480 array"),
    "set_both_targets.xml": (5, "needs exactly one of quantity= or field="),
    "set_value_not_number.xml": (5, "<set value=...> must be a finite number, got 'fast'"),
    "sweep_log_nonpositive.xml": (6, "needs start and stop > 0"),
    "sweep_no_points.xml": (6, "sweep axis 'light' has no points"),
    "sweep_point_out_of_range.xml": (6, "'tx_low': 0.5 V is above its maximum 0"),
    "sweep_same_axis_twice.xml": (6, "sweeps 'sf_bias' on both axes"),
    "sweep_three_axes.xml": (6, "<axis> is not allowed here"),
    "sweep_without_axis.xml": (6, "<sweep> is missing"),
    "sweep_zero_points.xml": (6, "<linear points=...> must be >= 1, got '0'"),
    "system_adc_channels.xml": (9, "2 channels but interleave='none'"),
    "system_paced_wire.xml": (33, "applies to the direct simulator"),
    "system_unknown_sim_param.xml": (37, "<simulator>: unknown simulator parameter 'lag_fracton'"),
    "system_sim_contradicts_sensor.xml": (36, "simulator parameter 'adc_bits' = 10 contradicts the sensor's 12"),
    "system_sim_param_out_of_range.xml": (37, "<simulator>: "),  # wording: ares.sim.SensorParams
    "system_bad_access.xml": (13, "must be one of ro, wo, rw, got 'readonly'"),
    "system_replay_no_descriptor.xml": (13, "<replay> needs descriptor=... (an EMVA 1288 descriptor file) or <recording>"),
    "system_replay_descriptor_and_recordings.xml": (13, "takes either descriptor=... or <recording> elements"),
    "system_replay_no_exposure_control.xml": (12, "a <replay> system needs <controls exposure=...>"),
    "system_replay_with_simulator.xml": (13, "a <replay> system replays recorded data and cannot also declare <simulator>"),
    "system_bad_address.xml": (23, "<field address=...>"),
    "system_bad_param_type.xml": (34, "simulator parameter 'rows' must be of type int, got 'many'"),
    "system_controls_unknown.xml": (31, "<controls exposure='integration_time'> names no register field"),
    "system_duplicate_field.xml": (29, "repeats the name 'sf_bias'"),
    "system_field_bits.xml": (21, "'black_level': bit 19 does not fit"),
    "truncated.xml": (6, "not well-formed XML"),
    "undeclared_entity.xml": (8, "not well-formed XML (Entity 'undeclared' not defined)"),
    "undefined_system.xml": (3, "system file '../../../protocols/no_such_sensor.xml' not found"),
    "unknown_analysis.xml": (9, "got 'astrology'"),
    "unknown_attribute.xml": (6, "<stage> does not take attribute 'colour'"),
    "unknown_element.xml": (7, "<pause> is not allowed here"),
    "unknown_quantity.xml": (5, "got 'humidity'"),
    "unknown_register.xml": (5, "unknown register field 'sf_biass'"),
    "wrong_root.xml": (2, "got <experiment>"),
    "xxe_file.xml": (2, "<!DOCTYPE> declarations are not allowed"),
    "xxe_network.xml": (2, "<!DOCTYPE> declarations are not allowed"),
    # non-finite numbers, limits and defect thresholds, regions, instrument waits (issue 10)
    "set_value_nan.xml": (7, "<set value=...> must be a finite number, got 'NaN'"),
    "set_value_inf.xml": (7, "<set value=...> must be a finite number, got 'INF'"),
    "sweep_values_nan.xml": (7, "<values> must be a list of finite numbers"),
    "sweep_linear_inf.xml": (7, "<linear stop=...> must be a finite number, got '-INF'"),
    "limit_nan.xml": (10, "<limit max=...> must be a finite number"),
    "limit_misspelt.xml": (10, "limit on 'read_nosie_e': unknown quantity; did you mean 'read_noise_e'"),
    "limit_analysis_not_listed.xml": (10, "no analysis of this scan produces it (add <analysis name=\"ptc\"/>)"),
    "limit_wrong_analysis_path.xml": (10, "analysis 'decomposition' does not produce 'read_noise_e' (ptc, photon_counting does)"),
    "limit_no_analyses.xml": (9, "limit on 'Pt': no analysis of this scan produces it"),
    "limit_bad_path.xml": (10, "<limit quantity=...> must be well formed, got 'ptc..gain'"),
    "defect_unknown_threshold.xml": (9, "unknown defect parameter 'hot_e_per_second'"),
    "defect_threshold_nan.xml": (9, "<threshold value=...> must be a finite number, got 'NaN'"),
    "defect_threshold_out_of_range.xml": (9, "confirm_fraction=2.0 must be in (0, 1]"),
    "defect_threshold_order.xml": (8, "0 <= dead_fraction <= low_response_fraction <= 1 <= high_response_fraction"),
    "defect_threshold_fractional_count.xml": (9, "max_hot='2.5' must be a whole number"),
    "defect_mask_missing.xml": (8, "defect mask 'no_such_mask.png' is not a file"),
    "too_many_regions.xml": (8, "300 regions of analysis (at most 256"),
    "system_scale_nan.xml": (29, "<field scale=...> must be a finite number, got 'NaN'"),
    "system_offset_inf.xml": (29, "<field offset=...> must be a finite number, got 'INF'"),
    "system_settle_negative.xml": (56, "<chamber settle_s=...> must be >= 0, got '-1'"),
    "system_settle_timeout_zero.xml": (56, "<chamber settle_timeout_s=...> must be > 0, got '0'"),
    "system_tolerance_negative.xml": (56, "<chamber tolerance=...> must be > 0, got '-0.5'"),
    "system_poll_nan.xml": (56, "<chamber poll_s=...> must be a finite number"),
    "temperature_above_chamber.xml": (7, "temperature 100 C is outside the chamber's range <= 85 C"),
}


def test_corpus_is_complete():
    assert sorted(p.name for p in BROKEN.glob("*.xml")) == sorted(EXPECTED)
    assert len(EXPECTED) >= 30


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_broken_file_gives_one_sentence(name):
    line, fragment = EXPECTED[name]
    path = BROKEN / name
    with pytest.raises(InputError) as info:
        validate_one(str(path))
    msg = str(info.value)
    assert msg.startswith(f"{path}:{line}: "), msg
    assert fragment in msg, msg
    assert "\n" not in msg and "Traceback" not in msg
    assert "Element '" not in msg  # lxml wording is translated


@pytest.mark.parametrize("path", SCANS + SYSTEMS, ids=lambda p: p.name)
def test_shipped_files_validate(path):
    assert validate_file(path) in ("scan", "system")


def test_required_scans_are_shipped():
    names = {p.stem for p in SCANS}
    assert {"photon_transfer", "ptc_exposure", "dark_current", "temperature", "gain", "bias_sweep_2d",
            "adc_linearity", "lag"} <= names


def test_sim_sensor_register_map_is_the_simulators():
    assert load_system(ROOT / "protocols" / "sim_sensor.xml").registers == SIM_REGISTER_MAP


def test_black_widow_matches_the_slides():
    bw = load_system(ROOT / "protocols" / "black_widow.xml")
    assert (bw.sensor.cols, bw.sensor.rows, bw.sensor.cfa, bw.sensor.adc_bits) == (424, 405, "mono", 11)
    assert bw.sensor.adc_channels == 2 and bw.sensor.pixel_pitch_um == 3.3
    assert bw.registers.value_bits == 8 and bw.registers.field("exposure").count == 3
    assert bw.buses[0].address == 0x36 and bw.usb_grabber is not None


@pytest.mark.parametrize("path", SYSTEMS, ids=lambda p: p.name)
def test_system_round_trip(path, tmp_path):
    for csv in path.parent.glob("*.csv"):  # a photodiode's calibration table, named relative to the system file
        shutil.copy(csv, tmp_path / csv.name)
    a = load_system(path)
    save_system(a, tmp_path / path.name)
    b = load_system(tmp_path / path.name)
    assert a == b


@pytest.mark.parametrize("path", SCANS, ids=lambda p: p.name)
def test_scan_round_trip(path, tmp_path):
    shutil.copytree(ROOT / "protocols", tmp_path / "protocols")
    (tmp_path / "scans").mkdir()
    a = load_scan(path)
    save_scan(a, tmp_path / "scans" / path.name)
    b = load_scan(tmp_path / "scans" / path.name)
    assert a == b
    assert a.system == b.system


def test_frozen():
    sc = load_scan(ROOT / "scans" / "photon_transfer.xml")
    with pytest.raises(AttributeError):
        sc.frames = 3  # type: ignore[misc]


def test_system_override(tmp_path):
    sc = load_scan(ROOT / "scans" / "photon_transfer.xml", system_path=ROOT / "protocols" / "sim_sensor.xml")
    assert sc.system.name == "sim_sensor"
    with pytest.raises(InputError, match="system file not found"):
        load_scan(ROOT / "scans" / "photon_transfer.xml", system_path=tmp_path / "nope.xml")


def test_entities_never_expand(tmp_path):
    # Even without a DOCTYPE check, nothing outside the file may be read.
    p = tmp_path / "x.xml"
    p.write_text('<?xml version="1.0"?>\n<!DOCTYPE s [<!ENTITY e SYSTEM "file:///etc/hostname">]>\n<scan>&e;</scan>')
    with pytest.raises(InputError, match="not allowed"):
        validate_file(p)


def test_cli_validate(capsys):
    assert main(["validate", str(ROOT / "scans" / "photon_transfer.xml")]) == 0
    assert "valid scan file" in capsys.readouterr().out
    assert main(["validate", str(BROKEN / "frames_not_integer.xml"), str(ROOT / "scans" / "lag.xml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "frames_not_integer.xml:4: <frames> must be an integer >= 2" in err[0]
    assert main(["validate", "no/such/file.xml"]) == 2
    assert "file not found" in capsys.readouterr().err
