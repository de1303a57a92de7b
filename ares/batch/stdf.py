"""A lot as STDF V4 (Standard Test Data Format, the file every yield tool reads), written
through Semi-ATE's ``Semi-ATE-STDF`` records: ``ares lots export --stdf`` and ``ares batch
--stdf``.

Records, in the order of the standard: FAR, MIR (lot, ARES as tester and executive, start
time); per wafer a WIR, then per sensor a PIR, one PTR per measured quantity (the value,
its unit, the lot's static limits as LO/HI_LIMIT with the fail flag), one PTR for its SE,
a dynamic part-average-testing screen as its own test with the lot's own limits, and a PRR
(hard and soft bin, wafer x/y rounded to integers, serial as PART_ID, item path as
PART_TXT, the failed flag), and a WRR (parts and good parts of the wafer); sensors without
a wafer follow the wafers; then one SBR per soft bin and one HBR per hard bin (HEAD_NUM 255:
all sites; the bins the lot file declares -- with 0 parts too -- or the default ones, with
their names and pass/fail), a PCR and the MRR.

Every PTR carries its test's limits and unit (OPT_FLAG, LO/HI_LIMIT, UNITS), not only the
first of a test: a reader that takes one sensor's records alone sees the limits too.

The SE: STDF V4 has no field for a result's uncertainty. It goes into a test of its own,
``<quantity> SE`` (test number 3000 + n, the quantity's unit, no limits, "no pass/fail
indication"), right after the value's PTR: a number every yield tool reads, plots and
exports like any other, where the result's text fields (TEST_TXT, ALARM_ID) would hide it
in a string no tool parses. An SE that is not available (the estimator gives none) is a
PTR with TEST_FLG bit 1 set, "RESULT is not valid" -- STDF's own way to say a number is
absent -- never a made-up zero.

Test numbers: 1000 + the quantity's place in the sorted quantity list; its SE 3000 + the
same, its screen 5000 + the same. STDF keeps values as 4-byte floats (R*4): a figure reads
back as ``numpy.float32`` of the value. Sources: a judged lot (``from_judged``) or a lot of the results database
(``from_db``), the same structure either way.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

TEST_BASE, SE_BASE, SCREEN_BASE = 1000, 3000, 5000
HEAD, SITE, ALL_HEADS = 1, 1, 255
NO_XY = -32768  # STDF's missing wafer coordinate


def _bits(n: int) -> list[str]:
    """A B*1 field as Semi-ATE takes it: eight '0'/'1', bit 7 first."""
    return list(f"{n:08b}")


def _tests(quantities, static: dict, dynamic: dict, units: dict) -> list[dict]:
    out = []
    for k, q in enumerate(sorted(quantities)):
        lo, hi = static.get(q, (None, None))
        out.append({"num": TEST_BASE + k, "name": q, "quantity": q, "unit": units.get(q, ""), "lo": lo, "hi": hi})
        out.append({"num": SE_BASE + k, "name": f"{q} SE", "quantity": q, "unit": units.get(q, ""), "lo": None,
                    "hi": None, "se": True})
        if q in dynamic and dynamic[q][0] is not None:
            lo, hi, text = dynamic[q]
            out.append({"num": SCREEN_BASE + k, "name": text, "quantity": q, "unit": units.get(q, ""), "lo": lo,
                        "hi": hi, "screen": True})
    return out


def _limits_of(screens: list[dict]) -> tuple[dict, dict]:
    from ares.batch.vocabulary import canonical

    static, dynamic = {}, {}
    for s in screens:
        q = canonical(s["quantity"])
        if s["kind"] == "static":
            lo, hi = static.get(q, (None, None))  # (two limits on one quantity: the narrower bounds)
            lo = s["low"] if lo is None else (lo if s["low"] is None else max(lo, s["low"]))
            hi = s["high"] if hi is None else (hi if s["high"] is None else min(hi, s["high"]))
            static[q] = (lo, hi)
        else:
            dynamic[q] = (s.get("low"), s.get("high"), s["screen"])
    return static, dynamic


def from_judged(j, name: str) -> dict:
    """The STDF content of a judged (and screened) lot."""
    parts, units = [], {}
    for r in j.results:
        vals, ses = {}, {}
        for q, f in (r.get("figures") or {}).items():
            units.setdefault(q, f.get("unit") or "")
            if f.get("value") is not None:
                vals[q] = float(f["value"])
                ses[q] = None if f.get("se") is None else float(f["se"])
        parts.append({"id": r.get("sensor") or Path(r["item"]).name, "text": r["item"], "wafer": r.get("wafer") or "",
                      "x": r.get("x"), "y": r.get("y"), "hard": r.get("hard_bin"), "soft": r.get("soft_bin"),
                      "error": r.get("status") == "error", "passed": r.get("passed"), "values": vals, "ses": ses,
                      "static_ok": all(v is not False for k, v in (r.get("checks") or {}).items()
                                       if not k.startswith("PAT "))})
    static, dynamic = _limits_of(j.screens)
    return {"name": name, "tests": _tests(j.quantities, static, dynamic, units), "parts": parts, "bins": j.bins,
            "started": int(time.time())}


def from_db(db, lot_id: int) -> dict:
    """The STDF content of a lot of the results database."""
    import datetime

    from ares.batch import db as rdb

    info = rdb.lot_info(db, lot_id)
    cols, rows = rdb.item_rows(db, lot_id)
    figs = rdb.figures(db, lot_id)
    units = {q: f.get("unit") or "" for fs in figs.values() for q, f in fs.items()}
    static, dynamic = _limits_of(rdb.screens(db, lot_id))
    parts = []
    for idx, row in enumerate(rows):
        r = dict(zip(cols, row))
        limit_cols = [c for c in cols if c not in rdb.ITEM_COLUMNS and c not in rdb.BIN_COLUMNS
                      and c not in units and not c.endswith("_se")]
        parts.append({"id": r["serial"] or Path(r["item"]).name, "text": r["item"], "wafer": r["wafer"] or "",
                      "x": r["x"], "y": r["y"], "hard": r["hard_bin"], "soft": r["soft_bin"],
                      "error": r["status"] == "error", "passed": {"pass": True, "FAIL": False}.get(r["verdict"]),
                      "values": {q: float(f["value"]) for q, f in figs.get(idx, {}).items() if f["value"] is not None},
                      "ses": {q: None if f["se"] is None else float(f["se"]) for q, f in figs.get(idx, {}).items()
                              if f["value"] is not None},
                      "static_ok": all(r[c] != "FAIL" for c in limit_cols if not c.startswith("PAT "))})
    try:
        started = int(datetime.datetime.fromisoformat(info["created"]).timestamp())
    except ValueError:
        started = int(time.time())
    return {"name": info["name"], "tests": _tests(units, static, dynamic, units), "parts": parts,
            "bins": rdb.bins(db, lot_id), "started": started}


def _rec(kind: str, **values):
    import Semi_ATE.STDF as S

    r = getattr(S, kind)(endian="<")
    for k, v in values.items():
        r.set_value(k, v)
    return r.__repr__()  # (Semi-ATE packs a record in __repr__: the record's bytes)


def _ptr(t: dict, v: float | None) -> bytes:
    """A PTR of test ``t`` with result ``v`` (None: not available -- TEST_FLG bit 1, RESULT
    not valid) and the test's limits and unit."""
    valid = v is not None and math.isfinite(v)
    judged = t["lo"] is not None or t["hi"] is not None
    fail = judged and (not valid or (t["lo"] is not None and v < t["lo"]) or (t["hi"] is not None and v > t["hi"]))
    flg = (0x80 if fail else 0) | (0 if judged else 0x40)  # bit 7 failed; bit 6 no pass/fail indication
    flg |= 0 if valid else 0x02  # bit 1: RESULT is not valid
    opt = 0x01 | (0x04 | 0x08)  # results not scaled... (bit 0: RES_SCAL invalid), no spec limits (bits 2, 3)
    opt |= 0x40 if t["lo"] is None else 0  # bit 6: no low limit
    opt |= 0x80 if t["hi"] is None else 0  # bit 7: no high limit
    fields = dict(TEST_NUM=t["num"], HEAD_NUM=HEAD, SITE_NUM=SITE, TEST_FLG=_bits(flg), PARM_FLG=_bits(0),
                  RESULT=float(v) if valid else 0.0, TEST_TXT=t["name"], ALARM_ID="",
                  OPT_FLAG=_bits(opt), RES_SCAL=0, LLM_SCAL=0, HLM_SCAL=0,
                  LO_LIMIT=float(t["lo"] or 0.0), HI_LIMIT=float(t["hi"] or 0.0), UNITS=t["unit"],
                  C_RESFMT="", C_LLMFMT="", C_HLMFMT="", LO_SPEC=0.0, HI_SPEC=0.0)
    return _rec("PTR", **fields)


def _xy(v) -> int:
    return NO_XY if v is None or not math.isfinite(float(v)) else int(round(float(v)))


def write(lot: dict, path: Path) -> int:
    """Write the lot's STDF V4 file (as .tmp, renamed); the number of records."""
    from ares import __version__

    t0 = lot["started"]
    out = [_rec("FAR", CPU_TYPE=2, STDF_VER=4),
           _rec("MIR", SETUP_T=t0, START_T=t0, STAT_NUM=1, LOT_ID=lot["name"], PART_TYP="image sensor",
                NODE_NAM="ares", TSTR_TYP="ARES", JOB_NAM="ares batch", EXEC_TYP="ARES", EXEC_VER=__version__)]
    wafers: dict[str, list[dict]] = {}
    for p in lot["parts"]:
        wafers.setdefault(p["wafer"], []).append(p)
    order = [w for w in wafers if w] + ([""] if "" in wafers else [])
    for w in order:
        if w:
            out.append(_rec("WIR", HEAD_NUM=HEAD, SITE_GRP=255, START_T=t0, WAFER_ID=w))
        for p in wafers[w]:
            out.append(_rec("PIR", HEAD_NUM=HEAD, SITE_NUM=SITE))
            n = 0
            for t in lot["tests"]:
                v = p["values"].get(t["quantity"])
                if v is None or (t.get("screen") and not p["static_ok"]):
                    continue  # not measured; or failed before the screen: not tested by it
                out.append(_ptr(t, p["ses"].get(t["quantity"]) if t.get("se") else v))
                n += 1
            flag = 0x08 if (p["error"] or p["passed"] is False) else 0  # bit 3: part failed
            flag |= 0x10 if p["passed"] is None and not p["error"] else 0  # bit 4: no pass/fail indication
            out.append(_rec("PRR", HEAD_NUM=HEAD, SITE_NUM=SITE, PART_FLG=_bits(flag), NUM_TEST=n,
                            HARD_BIN=p["hard"] if p["hard"] is not None else 0,
                            SOFT_BIN=p["soft"] if p["soft"] is not None else 65535,
                            X_COORD=_xy(p["x"]), Y_COORD=_xy(p["y"]), TEST_T=0, PART_ID=p["id"],
                            PART_TXT=p["text"], PART_FIX=[]))
        if w:
            ps = wafers[w]
            out.append(_rec("WRR", HEAD_NUM=HEAD, SITE_GRP=255, FINISH_T=t0, PART_CNT=len(ps), RTST_CNT=0,
                            ABRT_CNT=0, GOOD_CNT=sum(p["passed"] is True for p in ps), FUNC_CNT=0, WAFER_ID=w,
                            FABWF_ID="", FRAME_ID="", MASK_ID="", USR_DESC="", EXC_DESC=""))
    hard: dict[int, list] = {}
    for sb, b in lot["bins"].items():
        pf = "P" if b["pass"] else "F"
        out.append(_rec("SBR", HEAD_NUM=ALL_HEADS, SITE_NUM=0, SBIN_NUM=int(sb), SBIN_CNT=b["count"], SBIN_PF=pf,
                        SBIN_NAM=b["name"]))
        h = hard.setdefault(b["hard"], [0, pf, b["hard_name"]])
        h[0] += b["count"]
    for hb, (n, pf, name) in sorted(hard.items()):
        out.append(_rec("HBR", HEAD_NUM=ALL_HEADS, SITE_NUM=0, HBIN_NUM=hb, HBIN_CNT=n, HBIN_PF=pf, HBIN_NAM=name))
    parts = lot["parts"]
    out.append(_rec("PCR", HEAD_NUM=ALL_HEADS, SITE_NUM=0, PART_CNT=len(parts), RTST_CNT=0, ABRT_CNT=0,
                    GOOD_CNT=sum(p["passed"] is True for p in parts), FUNC_CNT=0))
    out.append(_rec("MRR", FINISH_T=int(time.time()), DISP_COD=" ", USR_DESC="", EXC_DESC=""))
    from ares.rundir.files import storage, write_atomic

    with storage(path):
        write_atomic(Path(path), b"".join(out))
    return len(out)
