"""Limit names are checked against what the scan's analyses produce (ares.protocol.quantities):
the table must cover every quantity an analysis really outputs, and the checks accept
exactly the names a limit can match at run time."""

from __future__ import annotations

from pathlib import Path

import pytest

from ares.protocol.quantities import PRODUCES, unknown_limit
from ares.results.registry import flatten, names_quantity

ROOT = Path(__file__).resolve().parents[1]
NOT_QUANTITIES = {"analog_gain", "exposure", "light", "temperature_c", "levels", "samples", "ref_c", "signal",
                  "index_u_ysat", "n_pixels", "n_frames", "cluster_min_size", "a00_se",
                  "scatter_ratio"}  # (the PTC decision errors: measured scatter over claimed, a diagnostic)
SCAN = """<?xml version="1.0" encoding="UTF-8"?>
<scan name="all_analyses" version="1">
  <system href="{system}"/>
  <settings><set quantity="analog_gain" value="1"/></settings>
  <frames>4</frames>
  <stages>
    <sweep name="dark" scene="dark"><axis quantity="exposure"><values>0.01 0.05 0.1</values></axis></sweep>
    <sweep name="ptc" scene="flat" dark="matched">
      <set quantity="exposure" value="0.01"/>
      <axis quantity="light"><log start="10000" stop="3000000" points="8"/></axis>
    </sweep>
  </stages>
  <analyses>
    <analysis name="decomposition"/><analysis name="ptc"/><analysis name="dark_current"/>
    <analysis name="defects"/><analysis name="emva1288"/>
  </analyses>
</scan>
"""


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    from ares.protocol import load_scan
    from ares.scan import Runner

    d = tmp_path_factory.mktemp("q")
    (d / "scan.xml").write_text(SCAN.format(system=ROOT / "fixtures" / "xml" / "small" / "sim_small.xml"))
    import dataclasses

    scan = load_scan(d / "scan.xml")  # (its scan_results are checked: no PDF)
    out = Runner(dataclasses.replace(scan, output=dataclasses.replace(scan.output, pdf=False)), out_dir=d / "run").run()
    assert out.status == "done"
    return out.scan_results


def test_every_produced_quantity_is_in_the_table(results):
    produced_any = False
    for analysis, r in results.items():
        leaves = {k.split(".")[-1] for k in flatten(r)} - NOT_QUANTITIES
        leaves = {x for x in leaves if not x.startswith("reg:")}
        assert leaves <= PRODUCES[analysis], (analysis, sorted(leaves - PRODUCES[analysis]))
        produced_any |= bool(leaves)
    assert produced_any and {"ptc", "decomposition", "dark_current", "defects"} <= set(results)


@pytest.mark.parametrize("q, ok", [("read_noise_e", True), ("ptc.read_noise_e", True), ("decomposition.Pt", True),
                                   ("Pt", True), ("ptc.Pt", False), ("read_nosie_e", False), ("doubling_temperature_c", False)])
def test_what_validates_is_what_matches(results, q, ok):
    analyses = tuple(results)
    assert (unknown_limit(q, analyses) is None) == ok
    if ok:  # a name the validator accepts finds its value in the results
        assert any(names_quantity(k, q) for k in flatten(results))
