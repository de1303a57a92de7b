"""Two-pass streaming: the project's StackAccumulator feeds pass 1, a SeriesCollector pass 2."""

import numpy as np
import pytest

from ares.analysis.defects import (PixelStats, SeriesCollector, classify_defects, classify_regions,
                                   classify_stack)

from defect_injection import inject

acc_mod = pytest.importorskip("ares.analysis.noise.accumulate")


@pytest.fixture(scope="module")
def inj():
    return inject(rows=64, cols=96, seed=21, rate_ppm=3000.0, bad_columns=1)


def test_accumulator_then_collector_equals_stack(inj):
    acc = acc_mod.StackAccumulator(inj.dark.shape[1:])
    for frame in inj.dark:  # pass 1: frames stream by, only statistics are kept
        acc.add(frame)
    dark = PixelStats.from_accumulator(acc, inj.exposure_s)
    pass1 = classify_defects(dark, gain_dn_per_e=inj.gain)
    col = SeriesCollector(*pass1.rts_candidates)
    for frame in inj.dark:  # pass 2: a second pass keeps only the candidates' series
        col.add(frame)
    assert col.series.shape == (inj.dark.shape[0], pass1.rts_candidates[0].size)
    res = classify_defects(dark, gain_dn_per_e=inj.gain, rts_series=col)
    ref = classify_stack(inj.dark, gain_dn_per_e=inj.gain, exposure_s=inj.exposure_s)
    np.testing.assert_array_equal(res.mask, ref.mask)
    r, c = inj.truth["rts"]
    assert res.class_map("rts")[r, c].mean() >= 0.99


def test_collector_per_channel(inj):
    acc = acc_mod.StackAccumulator(inj.dark.shape[1:])
    for frame in inj.dark:
        acc.add(frame)
    dark = PixelStats.from_accumulator(acc, inj.exposure_s)
    regions = {f"{a}{b}": (slice(a, None, 2), slice(b, None, 2)) for a in (0, 1) for b in (0, 1)}
    # candidates from a whole-frame pass 1 (a superset is fine)
    pass1 = classify_defects(dark, gain_dn_per_e=inj.gain)
    col = SeriesCollector(*pass1.rts_candidates)
    for frame in inj.dark:
        col.add(frame)
    out = classify_regions(dark, None, regions, gain_dn_per_e=inj.gain, rts_series=col)
    found = {(int(d["y"]), int(d["x"])) for res in out.values() for d in res.defects if d["cls"] == "rts"}
    truth = set(zip(*(a.tolist() for a in inj.truth["rts"])))
    assert len(found & truth) >= 0.95 * len(truth)
    assert all(res.rts_available for res in out.values())
