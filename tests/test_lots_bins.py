"""Bins declared in the lot file (``<bins>``: hard bins with name and pass/fail, soft bins
with their hard bin, name and role; limits and screens mapped by ``soft_bin=`` or by
``for="limit"``/``for="pat"``), judged against the truth planted in the synthetic lot of
test_lots_screens: every item in the declared bin of its planted kind, every declared bin
listed (with 0 items too), the same bins in the database and in STDF's HBR/SBR (read back
with pystdf); every bad declaration one sentence naming the file and line."""

from __future__ import annotations

import pytest

from ares.batch import db as rdb
from ares.batch import stdf
from ares.batch.lot_report import judge
from ares.batch.screens import screen
from ares.cli import main
from ares.errors import InputError
from ares.protocol.lot import load_lot
from test_lots_screens import planted

BINS = """<lot name="B" version="1">
  <limits>
    <limit quantity="gain_dn_per_e" min="0.25" max="0.40" soft_bin="21"/>
    <limit quantity="read_noise_e" max="9"/>
    <pat quantity="gain_dn_per_e" k="6"/>
  </limits>
  <bins>
    <hard number="8" name="good" pass="true"/>
    <hard number="5" name="parametric"/>
    <hard number="6" name="outlier"/>
    <hard number="7" name="no data"/>
    <soft number="2" hard="8" name="good die" for="pass"/>
    <soft number="21" hard="5" name="gain out of range"/>
    <soft number="22" hard="5" name="other limits" for="limit"/>
    <soft number="40" hard="6" name="gain outlier" for="pat"/>
    <soft number="97" hard="7" name="no figures" for="error"/>
  </bins>
</lot>
"""
WANT = {"pass": (8, 2), "limit": (5, 21), "outlier": (6, 40), "error": (7, 97)}


def test_declared_bins_take_the_planted_truth_into_the_database_and_stdf(tmp_path):
    from test_lots_stdf import read_stdf

    (tmp_path / "b.xml").write_text(BINS)
    lot = load_lot(tmp_path / "b.xml")
    res, truth = planted()
    j = judge(res, lot.limits)
    screen(j, lot.screens, lot.limit_bins, lot.hard_bins, lot.soft_bins)
    for r in j.results:
        assert (r["hard_bin"], r["soft_bin"]) == WANT[truth[r["item"]]], r["item"]
        assert r["passed"] is (truth[r["item"]] == "pass")
    counts = {k: sum(v == k for v in truth.values()) for k in WANT}
    want_bins = {2: (8, "good die", True, counts["pass"]), 21: (5, "gain out of range", False, counts["limit"]),
                 22: (5, "other limits", False, 0), 40: (6, "gain outlier", False, counts["outlier"]),
                 97: (7, "no figures", False, counts["error"])}
    got = {sb: (b["hard"], b["name"], b["pass"], b["count"]) for sb, b in j.bins.items()}
    assert got == want_bins  # every declared bin, the empty one too
    with rdb.connect(str(tmp_path / "r.sqlite")) as db:
        lot_id = rdb.append_lot(db, "B", j)
        assert rdb.bins(db, lot_id) == j.bins
        from_db = stdf.from_db(db, lot_id)
    for name, content in (("judged", stdf.from_judged(j, "B")), ("db", from_db)):
        stdf.write(content, tmp_path / f"{name}.stdf")
        recs = read_stdf(tmp_path / f"{name}.stdf")
        assert {b["SBIN_NUM"]: (b["SBIN_NAM"], b["SBIN_PF"], b["SBIN_CNT"]) for b in recs["SBR"]} == {
            sb: (nm, "P" if ok else "F", n) for sb, (_, nm, ok, n) in want_bins.items()}
        assert {b["HBIN_NUM"]: (b["HBIN_NAM"], b["HBIN_PF"], b["HBIN_CNT"]) for b in recs["HBR"]} == {
            8: ("good", "P", counts["pass"]), 5: ("parametric", "F", counts["limit"]),
            6: ("outlier", "F", counts["outlier"]), 7: ("no data", "F", counts["error"])}
        assert sorted((p["HARD_BIN"], p["SOFT_BIN"]) for p in recs["PRR"]) == sorted(
            (r["hard_bin"], r["soft_bin"]) for r in j.results)


BAD = [  # (change to BINS, the line named, what the sentence says)
    ('<hard number="5" name="parametric"/>', '<hard number="8" name="parametric"/>', 9, "hard bin 8 is declared twice"),
    ('hard="6" name="gain outlier"', 'hard="9" name="gain outlier"', 15, "hard bin 9, which <bins> does not declare"),
    ('name="gain outlier" for="pat"', 'name="gain outlier" for="limit"', 15, 'soft bins 22 and 40 are both for="limit"'),
    ('hard="8" name="good die"', 'hard="5" name="good die"', 12, "its hard bin 5 is not a pass bin"),
    ('hard="7" name="no figures"', 'hard="8" name="no figures"', 16, "failed items would count as good"),
    ('    <soft number="97" hard="7" name="no figures" for="error"/>\n', '', 7, 'no soft bin for="error"'),
    ('soft_bin="21"', 'soft_bin="23"', 3, "soft bin 23 is not declared in <bins>"),
    ('soft_bin="21"', 'soft_bin="2"', 3, "soft bin 2 takes good items"),
    (' for="limit"', '', 4, "limit on 'read_noise_e' has no soft_bin= and <bins> declares no soft bin"),
    ('number="97"', 'number="40000"', 16, "40000"),
]


@pytest.mark.parametrize("old,new,line,says", BAD, ids=[b[3][:30] for b in BAD])
def test_a_bad_bin_declaration_is_one_sentence_naming_the_line(old, new, line, says, tmp_path, capsys):
    assert old in BINS
    (tmp_path / "b.xml").write_text(BINS.replace(old, new, 1))
    with pytest.raises(InputError) as e:
        load_lot(tmp_path / "b.xml")
    msg = str(e.value)
    assert f"b.xml:{line}:" in msg and says in msg and "\n" not in msg, msg
    assert main(["batch", "--lot", str(tmp_path / "b.xml"), "--out", str(tmp_path / "o"), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and f"b.xml:{line}:" in err


def test_without_bins_the_default_pass_and_error_soft_bins_are_reserved(tmp_path):
    f = tmp_path / "l.xml"
    f.write_text('<lot name="L" version="1">\n<limits>\n<limit quantity="K" min="0.2" soft_bin="99"/>\n</limits>\n</lot>')
    with pytest.raises(InputError, match=r"l.xml:3: limit on 'K': soft bin 99 is the default error bin"):
        load_lot(f)


def test_declared_bins_without_limits_sort_good_from_unanalysable(tmp_path):
    start, end = BINS.index("  <limits>"), BINS.index("  <bins>")
    (tmp_path / "b.xml").write_text(BINS[:start] + BINS[end:])
    lot = load_lot(tmp_path / "b.xml")
    res, truth = planted(60)
    j = judge(res, lot.limits)
    screen(j, lot.screens, lot.limit_bins, lot.hard_bins, lot.soft_bins)
    for r in j.results:
        assert (r["hard_bin"], r["soft_bin"]) == ((7, 97) if truth[r["item"]] == "error" else (8, 2))
    assert {sb: b["count"] for sb, b in j.bins.items()} == {2: 59, 21: 0, 22: 0, 40: 0, 97: 1}
