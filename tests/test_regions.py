"""Regions, Bayer/ADC channels, OB columns: zero-copy views and clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.noise.regions import (
    Region,
    SelectionSet,
    adc_channels,
    bayer_channels,
    ob_columns,
    parse_roi,
    region_selection,
)
from ares.errors import InputError

SHAPE = (12, 16)
FRAME = np.arange(12 * 16, dtype=np.uint16).reshape(SHAPE)


def test_region_is_view_and_right_pixels():
    s = region_selection(Region(3, 2, 5, 4), SHAPE)
    v = s(FRAME)
    assert np.shares_memory(v, FRAME)
    np.testing.assert_array_equal(v, FRAME[2:6, 3:8])
    assert s.shape(SHAPE) == (4, 5)


def test_bayer_phases_absolute_parity():
    chans = bayer_channels(SHAPE, "RGGB")
    assert [c.name for c in chans] == ["R", "Gr", "Gb", "B"]
    np.testing.assert_array_equal(chans[0](FRAME), FRAME[0::2, 0::2])
    np.testing.assert_array_equal(chans[3](FRAME), FRAME[1::2, 1::2])
    # a region starting on odd row/column keeps the sensor's colours
    sub = bayer_channels(SHAPE, "RGGB", Region(1, 1, 8, 6))
    np.testing.assert_array_equal(sub[0](FRAME), FRAME[2:7:2, 2:9:2])
    assert all(np.shares_memory(c(FRAME), FRAME) for c in sub)
    assert [c.name.split()[-1] for c in bayer_channels(SHAPE, "GBRG")] == ["Gb", "B", "R", "Gr"]
    with pytest.raises(InputError, match="CFA"):
        bayer_channels(SHAPE, "RGBX")


def test_adc_interleave():
    ch = adc_channels(SHAPE, 2)
    np.testing.assert_array_equal(ch[1](FRAME), FRAME[:, 1::2])
    ch4 = adc_channels(SHAPE, 4, Region(2, 0, 10, 12))
    np.testing.assert_array_equal(ch4[0](FRAME), FRAME[:, 4:12:4])
    np.testing.assert_array_equal(ch4[3](FRAME), FRAME[:, 3:12:4])


def test_ob_and_errors():
    ob = ob_columns(SHAPE, 0, 3)
    np.testing.assert_array_equal(ob(FRAME), FRAME[:, :3])
    with pytest.raises(InputError, match="outside the 16x12 frame"):
        region_selection(Region(10, 0, 8, 4, name="right"), SHAPE)
    with pytest.raises(InputError, match="region 'neg'"):
        region_selection(Region(-1, 0, 2, 2, name="neg"), SHAPE)
    with pytest.raises(InputError, match="optically black"):
        ob_columns(SHAPE, 10, 20)
    with pytest.raises(InputError, match="four integers"):
        parse_roi("1,2,3")
    assert parse_roi("1,2,3,4") == Region(1, 2, 3, 4, name="roi 1,2,3,4")


def test_selection_set_one_accumulator_each():
    rng = np.random.default_rng(0)
    stack = rng.integers(0, 4096, (7,) + SHAPE).astype(np.uint16)
    sels = [Region(0, 0, 8, 6, name="a"), Region(4, 4, 8, 8, name="off", enabled=False)]
    sels += bayer_channels(SHAPE, "RGGB") + adc_channels(SHAPE, 2) + [ob_columns(SHAPE, 0, 2)]
    ss = SelectionSet(SHAPE, sels)
    assert "off" not in ss.accumulators
    for f in stack:
        ss.add(f)
    np.testing.assert_allclose(ss["a"].mean_map(), stack[:, :6, :8].mean(0))
    np.testing.assert_allclose(ss["Gb"].temporal_var_map(), stack[:, 1::2, 0::2].astype(float).var(0, ddof=1))
    ss2 = SelectionSet(SHAPE, sels)
    ss2.add_batch(stack)
    for name, acc in ss.items():
        assert np.array_equal(acc.temporal_var_map(), ss2[name].temporal_var_map())
    with pytest.raises(InputError, match="shape"):
        ss.add(np.zeros((3, 3), np.uint16))
