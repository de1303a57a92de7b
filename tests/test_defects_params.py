"""DefectThresholds: defaults, XML attribute conversion, one-sentence errors, limits."""

import json

import numpy as np
import pytest

from ares.analysis.defects import DefectThresholds, classify_stack
from ares.errors import InputError


def test_defaults_follow_science_notes():
    th = DefectThresholds()
    assert th.hot_e_per_s == 5.0 and th.warm_z == 4.8
    assert th.low_response_fraction == 0.8 and th.dead_fraction == 0.5
    assert th.stuck_var_dn2 == pytest.approx(1 / 12)
    assert th.rts_min_frames == 12 and th.confirm_fraction == 0.7  # issue 34: RTS from 12 frames
    assert th.line_hot_count == 20 and th.line_dead_count == 100
    assert th.limits() == {}


def test_from_attrs_converts_strings():
    th = DefectThresholds.from_attrs({"hot_e_per_s": "7.5", "line_hot_count": "12", "max_hot": "3",
                                      "max_rts": "none"})
    assert th.hot_e_per_s == 7.5 and th.line_hot_count == 12 and isinstance(th.line_hot_count, int)
    assert th.limits() == {"hot": 3}


def _one_sentence(msg: str) -> bool:
    return "\n" not in msg and msg.count(". ") == 0


@pytest.mark.parametrize("attrs, words", [
    ({"hot_e_per_sec": "5"}, ["unknown defect parameter", "hot_e_per_sec"]),
    ({"hot_e_per_s": "five"}, ["hot_e_per_s", "not a number"]),
    ({"line_hot_count": "2.5"}, ["line_hot_count", "whole number"]),
    ({"confirm_fraction": "1.5"}, ["confirm_fraction", "(0, 1]"]),
    ({"dead_fraction": "0.9"}, ["dead_fraction"]),
    ({"warm_e_per_s": "50"}, ["warm_e_per_s"]),
    ({"hot_z": "-1"}, ["hot_z"]),
])
def test_bad_attrs_raise_one_sentence(attrs, words):
    with pytest.raises(InputError) as ei:
        DefectThresholds.from_attrs(attrs, where="scan.xml:12")
    msg = str(ei.value)
    assert _one_sentence(msg), msg
    for w in words:
        assert w in msg


def test_limits_pass_fail_and_json():
    rng = np.random.default_rng(1)
    dark = (100 + rng.normal(0, 2, (100, 64, 80))).round().astype(np.uint16)
    dark[:, 10, 10] += 80  # one hot pixel
    res = classify_stack(dark, thresholds=DefectThresholds(max_hot=0, max_total=5))
    lim = {x["name"]: x for x in res.limits}
    assert lim["hot"]["count"] == 1 and lim["hot"]["passed"] is False
    assert lim["total"]["passed"] is True
    assert not res.passed
    json.dumps(res.to_dict())  # serializable
    ok = classify_stack(dark, thresholds=DefectThresholds(max_hot=1))
    assert ok.passed


def test_whole_floats_accepted_for_counts():
    th = DefectThresholds(line_hot_count=20.0, max_hot=3.0)  # as a scan XML <threshold value=...> gives them
    assert th.line_hot_count == 20 and isinstance(th.line_hot_count, int) and th.limits() == {"hot": 3}
    with pytest.raises(InputError, match="whole number"):
        DefectThresholds(rts_min_frames=99.5)
