"""SensorParams: defaults, units, validation sentences, dict round trip."""

import pytest

from ares.errors import InputError
from ares.sim import SensorParams


def test_defaults_are_a_realistic_small_cmos_sensor():
    p = SensorParams()
    assert (p.rows, p.cols, p.adc_bits) == (480, 640, 12)
    assert 10_000 <= p.full_well_e <= 20_000
    assert 60 <= p.conversion_gain_uv_per_e <= 80
    assert 2 <= p.read_noise_e <= 3
    # full well fits the ADC range at x1 with the default black level
    assert p.gain_dn_per_e(1.0) * p.full_well_e + 64 < p.max_code


def test_gain_formula():
    p = SensorParams(conversion_gain_uv_per_e=80.0, adc_lsb_uv=200.0)
    assert p.gain_dn_per_e(1.0) == pytest.approx(0.4)
    assert p.gain_dn_per_e(2.5) == pytest.approx(1.0)


def test_dark_scale_doubles_every_8_c():
    p = SensorParams()
    assert p.dark_scale(60.0) == pytest.approx(1.0)
    assert p.dark_scale(68.0) == pytest.approx(2.0)
    assert p.dark_scale(44.0) == pytest.approx(0.25)


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"read_noise_e": -1.0}, "read_noise_e"),
        ({"col_temporal_dn": -0.1}, "col_temporal_dn"),
        ({"adc_bits": 0}, "adc_bits"),
        ({"adc_bits": 17}, "adc_bits"),
        ({"full_well_e": 0.0}, "full_well_e"),
        ({"full_well_e": -5.0}, "full_well_e"),
        ({"rows": 1}, "rows"),
        ({"cols": 10.0}, "cols"),
        ({"qe": 1.5}, "qe"),
        ({"cfa": "RGBW"}, "cfa"),
        ({"prnu_pct": (1.0, 1.0)}, "prnu_pct"),
        ({"adc_gain": (1.0, 0.0)}, "adc_gain"),
        ({"ob_columns": 64, "cols": 64}, "ob_columns"),
        ({"lag_fraction": 1.0}, "lag_fraction"),
        ({"dark_current_e_per_s": float("nan")}, "dark_current_e_per_s"),
        ({"stuck_code_dn": 5000}, "stuck_code_dn"),
    ],
)
def test_bad_values_raise_one_sentence_naming_the_field(changes, field):
    with pytest.raises(InputError) as e:
        SensorParams(**changes)
    msg = str(e.value)
    assert f"'{field}'" in msg
    assert "\n" not in msg and msg.count(". ") == 0


def test_unknown_fields_are_listed():
    with pytest.raises(InputError, match=r"unknown simulator parameter 'foo'$"):
        SensorParams.from_dict({"rows": 64, "foo": 1})
    with pytest.raises(InputError, match=r"unknown simulator parameters 'bar', 'foo'"):
        SensorParams.from_dict({"foo": 1, "bar": 2})


def test_dict_round_trip_and_lists_become_tuples():
    p = SensorParams(rows=64, cols=48, prnu_pct=[1, 2, 3, 4], cfa="GRBG")
    assert p.prnu_pct == (1.0, 2.0, 3.0, 4.0)
    assert SensorParams.from_dict(p.to_dict()) == p
    assert p.replace(rows=32).rows == 32


def test_without_defects_and_noiseless_helpers():
    p = SensorParams().without_defects()
    assert p.hot_rate_ppm == p.dead_rate_ppm == p.bad_columns == 0
    n = SensorParams().noiseless()
    assert n.read_noise_e == n.col_fpn_dn == n.dark_current_e_per_s == 0
    assert n.prnu_pct == (0.0,) * 4


def test_types_are_checked_and_cfa_names_normalized():
    with pytest.raises(InputError, match="'read_noise_e' must be a number"):
        SensorParams(read_noise_e="2.5")
    with pytest.raises(InputError, match="mapping"):
        SensorParams.from_dict([("rows", 4)])
    assert SensorParams(read_noise_e=3).read_noise_e == 3.0
    assert SensorParams(cfa="rggb").cfa == "RGGB"
    assert SensorParams(cfa="mono").cfa is None
