"""STDF V4 out of a lot (``ares.batch.stdf``, written with Semi-ATE's records), read back
with ``pystdf`` (an independent reader): every PTR's value equal to the figure (as the
4-byte float STDF stores), its limits and fail flag, every PRR's bins, wafer x/y and part
id, a WRR per wafer, HBR/SBR counts equal to the lot's bins -- from the judged lot and from
the results database (``ares lots export --stdf``) alike."""

from __future__ import annotations

import numpy as np
import pytest

from ares.batch import db as rdb
from ares.batch import stdf
from ares.cli import main
from test_lots_screens import _judged

pytest.importorskip("pystdf")


def read_stdf(path) -> dict[str, list[dict]]:
    """Every record of an STDF file by type, as pystdf parses it."""
    from pystdf.IO import Parser

    out: dict[str, list[dict]] = {}

    class Sink:
        def after_send(self, _src, data):
            rec, vals = data
            out.setdefault(type(rec).__name__.upper(), []).append(dict(zip(rec.fieldNames, vals)))

        def __getattr__(self, _name):
            return lambda *a: None

    with open(path, "rb") as fh:
        p = Parser(inp=fh)
        p.addSink(Sink())
        p.parse()
    return out


def lot_with_wafers():
    j, truth = _judged()
    for i, r in enumerate(j.results):
        r.update(wafer=f"W{i % 4 + 1}", x=float(i // 4 % 10), y=float(i // 40), sensor=f"SN{i:04d}")
        if i % 13 == 0 and r.get("figures"):  # an SE the estimator could not give
            r["figures"]["read_noise_e"]["se"] = None
    return j, truth


def check_against(recs: dict, j) -> None:
    f32 = lambda v: float(np.float32(v))  # noqa: E731 -- STDF's R*4
    assert len(recs["FAR"]) == len(recs["MIR"]) == len(recs["MRR"]) == 1 and recs["FAR"][0]["STDF_VER"] == 4
    prr, ptr = recs["PRR"], recs["PTR"]
    assert [p["PART_ID"] for p in prr] == [r["sensor"] for r in sorted(j.results, key=lambda r: r["wafer"])]
    by_id = {r["sensor"]: r for r in j.results}
    # PTRs sit between their PIR and PRR: walk them in order
    k = 0
    limits = {}
    for p in prr:
        r = by_id[p["PART_ID"]]
        assert (p["HARD_BIN"], p["SOFT_BIN"]) == (r["hard_bin"], r["soft_bin"])
        assert (p["X_COORD"], p["Y_COORD"]) == (int(r["x"]), int(r["y"]))
        assert bool(p["PART_FLG"] & 0x08) is (not r["passed"])
        mine = ptr[k:k + p["NUM_TEST"]]
        k += p["NUM_TEST"]
        figs = r.get("figures") or {}
        values = [t for t in mine if t["TEST_NUM"] < stdf.SE_BASE]
        assert {t["TEST_TXT"] for t in values} == set(figs)
        for t in values:
            assert t["RESULT"] == f32(figs[t["TEST_TXT"]]["value"])
            se = mine[mine.index(t) + 1]  # the SE's own test, right after the value
            f = figs[t["TEST_TXT"]]
            assert (se["TEST_NUM"], se["TEST_TXT"]) == (t["TEST_NUM"] - stdf.TEST_BASE + stdf.SE_BASE,
                                                        f"{t['TEST_TXT']} SE")
            assert se["UNITS"] == t["UNITS"] and se["OPT_FLAG"] & 0xC0 == 0xC0 and se["TEST_FLG"] & 0x40
            if f["se"] is None:  # not available: STDF's "RESULT is not valid", never a number
                assert se["TEST_FLG"] & 0x02
            else:
                assert se["RESULT"] == f32(f["se"]) and not se["TEST_FLG"] & 0x02
        screens = [t for t in mine if t["TEST_NUM"] >= stdf.SCREEN_BASE]
        assert len(screens) == (1 if r["hard_bin"] in (1, 3) else 0)  # failed a static limit: not screened
        for t in mine:
            assert t["OPT_FLAG"] is not None and t["UNITS"] is not None  # every PTR carries its limits
            if t["TEST_NUM"] in limits:
                assert (t["LO_LIMIT"], t["HI_LIMIT"]) == (limits[t["TEST_NUM"]]["LO_LIMIT"],
                                                          limits[t["TEST_NUM"]]["HI_LIMIT"])
            if t["TEST_NUM"] not in limits:
                limits[t["TEST_NUM"]] = t
            limited = t["TEST_TXT"] == "gain_dn_per_e"  # (read_noise_e has no limit: never fails)
            assert bool(t["TEST_FLG"] & 0x80) is (r["hard_bin"] == 2 and limited or r["hard_bin"] == 3 and t in screens)
            assert bool(t["TEST_FLG"] & 0x40) is (not limited and t not in screens)  # no pass/fail indication
            if limited:
                assert (t["LO_LIMIT"], t["HI_LIMIT"]) == (f32(0.25), f32(0.40))
    assert k == len(ptr)
    stat = next(s for s in j.screens if s["kind"] == "static")
    dyn = next(s for s in j.screens if s["kind"] == "dynamic")
    g = next(t for t in limits.values() if t["TEST_TXT"] == "gain_dn_per_e")
    assert (g["LO_LIMIT"], g["HI_LIMIT"], g["UNITS"]) == (f32(stat["low"]), f32(stat["high"]), "DN/e-")
    pat = next(t for t in limits.values() if t["TEST_NUM"] >= stdf.SCREEN_BASE)
    assert (pat["LO_LIMIT"], pat["HI_LIMIT"]) == (f32(dyn["low"]), f32(dyn["high"]))
    rn = next(t for t in limits.values() if t["TEST_TXT"] == "read_noise_e")
    assert rn["OPT_FLAG"] & 0xC0 == 0xC0  # no limits on it
    assert {b["SBIN_NUM"]: b["SBIN_CNT"] for b in recs["SBR"]} == {sb: b["count"] for sb, b in j.bins.items()}
    hard = {}
    for b in j.bins.values():
        hard[b["hard"]] = hard.get(b["hard"], 0) + b["count"]
    assert {b["HBIN_NUM"]: b["HBIN_CNT"] for b in recs["HBR"]} == hard
    assert {w["WAFER_ID"]: (w["PART_CNT"], w["GOOD_CNT"]) for w in recs["WRR"]} == {
        f"W{n}": (sum(r["wafer"] == f"W{n}" for r in j.results),
                  sum(r["wafer"] == f"W{n}" and r["passed"] for r in j.results)) for n in range(1, 5)}
    assert [w["WAFER_ID"] for w in recs["WIR"]] == ["W1", "W2", "W3", "W4"]


def test_stdf_of_a_judged_lot_reads_back_equal(tmp_path):
    j, _ = lot_with_wafers()
    stdf.write(stdf.from_judged(j, "L7"), tmp_path / "l.stdf")
    recs = read_stdf(tmp_path / "l.stdf")
    assert recs["MIR"][0]["LOT_ID"] == "L7"
    check_against(recs, j)


def test_lots_export_stdf_from_the_database_reads_back_equal(tmp_path, capsys):
    j, _ = lot_with_wafers()
    path = str(tmp_path / "r.sqlite")
    with rdb.connect(path) as db:
        rdb.append_lot(db, "L7", j)
    assert main(["lots", "export", "L7", "--db", path, "--stdf", str(tmp_path / "db.stdf")]) == 0
    assert "STDF V4" in capsys.readouterr().err
    check_against(read_stdf(tmp_path / "db.stdf"), j)
