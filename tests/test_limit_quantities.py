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


def test_a_figure_known_only_as_a_limit_passes_a_limit_only_where_it_proves_it():
    """An upper limit "< 0.3" proves "<= 0.5" but not ">= 0.1" (the value may be 0); a lower limit
    "> 2" proves ">= 1" but not "<= 5": never a wrong pass (the value compared as if measured)."""
    from types import SimpleNamespace

    from ares.protocol.scan import Limit
    from ares.results.registry import check_limits

    res = {"lag": {"lag_pct": {"value": 0.3, "se": None, "unit": "%", "verdict": "upper limit"}},
           "ptc": {"full_well_e": {"value": 2.0, "se": None, "unit": "e-", "verdict": "lower limit"}}}

    def fails(*lims):
        return check_limits(SimpleNamespace(limits=list(lims)), res)

    assert fails(Limit("lag_pct", max=0.5), Limit("full_well_e", min=1.0)) == []
    f = fails(Limit("lag_pct", min=0.1, max=0.5))
    assert len(f) == 1 and "only an upper limit" in f[0] and "< 0.3" in f[0]
    f = fails(Limit("full_well_e", max=5.0))
    assert len(f) == 1 and "only a lower limit" in f[0]
    f = fails(Limit("lag_pct", max=0.2))
    assert len(f) == 1 and "< 0.3 is not <= 0.2" in f[0]
    # a lot's item likewise (the same rule: results.registry.limit_passes)
    from ares.batch.lot_report import judge

    j = judge([{"item": "a", "status": "done", "figures": {"lag_pct": res["lag"]["lag_pct"]}}],
              [Limit("lag_pct", min=0.1, max=0.5)])
    assert j.results[0]["passed"] is False
