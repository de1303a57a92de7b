"""Property test: any valid scan built from the sim system saves and loads back equal."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

from hypothesis import HealthCheck, given, settings, strategies as st

from ares.protocol import Axis, Limit, Output, Setting, StageSpec, load_scan, save_scan

ROOT = Path(__file__).resolve().parents[1]
BASE = load_scan(ROOT / "scans" / "photon_transfer.xml")

finite = dict(allow_nan=False, allow_infinity=False)
sf_bias = st.floats(0.0, 3.3, **finite)
tx_low = st.floats(-1.0, 0.0, **finite)
light = st.floats(0.0, 1e7, **finite)


@st.composite
def axes(draw):
    kind = draw(st.sampled_from(["values", "linear", "log"]))
    if kind == "values":
        return Axis("reg:sf_bias", "values", tuple(draw(st.lists(sf_bias, min_size=1, max_size=5))))
    lo, hi = sorted(draw(st.lists(st.floats(1.0, 1e6, **finite), min_size=2, max_size=2)))
    return Axis("light", kind, (), lo, hi, draw(st.integers(1, 6)))


@st.composite
def scans(draw):
    stages = []
    for i in range(draw(st.integers(1, 3))):
        ax = draw(st.lists(axes(), min_size=0, max_size=1))
        sets = (Setting("reg:tx_low", draw(tx_low)),) if draw(st.booleans()) else ()
        scene = "flat" if ax and ax[0].key == "light" else draw(st.sampled_from(["dark", "flat"]))
        stages.append(StageSpec(f"s{i}", scene, draw(st.one_of(st.none(), st.integers(2, 50))),
                                "matched" if scene == "flat" and draw(st.booleans()) else "none", None, sets,
                                tuple(ax), bool(ax)))
    lims = tuple(Limit(q, draw(st.floats(-1e3, 0, **finite)), draw(st.floats(1, 1e3, **finite)))
                 for q in draw(st.lists(st.sampled_from(["read_noise_e", "full_well_e"]), max_size=2, unique=True)))
    return dataclasses.replace(
        BASE, frames=draw(st.integers(2, 64)), stages=tuple(stages), limits=lims,
        settings=(Setting("exposure", draw(st.floats(1e-6, 100, **finite))), Setting("light", draw(light))),
        output=Output(*draw(st.tuples(st.booleans(), st.booleans(), st.booleans(), st.booleans()))))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(sc=scans())
def test_scan_round_trip_property(tmp_path, sc):
    if not (tmp_path / "protocols").exists():
        shutil.copytree(ROOT / "protocols", tmp_path / "protocols")
        (tmp_path / "scans").mkdir()
    p = tmp_path / "scans" / "x.xml"
    save_scan(sc, p)
    assert load_scan(p) == sc
