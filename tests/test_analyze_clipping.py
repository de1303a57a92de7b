"""`ares analyze` on clipped stacks (issue 48): a stack entirely at the format's maximum gives
every figure "not available" with the reason (it gave every component 0, "ok"); half the
pixels clipped are excluded and counted on every surface, and the figures equal those of the
unclipped half (it gave Pt halved and Cs 72 689 DN^2, "ok"). Truth: the unclipped stack."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ares.cli import main

SHAPE = (8, 48, 64)


def _stacks(seed=0):
    r = np.random.default_rng(seed)
    dark = np.round(1000 + r.normal(0, 5, SHAPE)).astype(np.uint16)
    flat = np.round(30000 + r.normal(0, 180, SHAPE)).astype(np.uint16)
    return dark, flat


def _run(capsys, *args):
    assert main(["analyze", *map(str, args), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_a_stack_entirely_at_65535_is_not_available(tmp_path, capsys):
    np.save(tmp_path / "sat.npy", np.full(SHAPE, 65535, np.uint16))
    out = _run(capsys, tmp_path / "sat.npy")
    for k in ("o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global"):
        assert out[k]["verdict"] == "not available" and "every pixel is clipped" in out[k]["note"], (k, out[k])
    c = out["_meta"]["clipping"]
    assert c["pixels"] == c["total"] == SHAPE[1] * SHAPE[2] and c["top_dn"] == 65535 and not c["excluded"]
    assert main(["analyze", str(tmp_path / "sat.npy")]) == 0
    text = capsys.readouterr().out
    assert "CLIPPED" in text and "no figure can be made" in text and " 0 DN" not in text


def test_a_stack_entirely_at_a_12_bit_adc_max(tmp_path, capsys):
    np.save(tmp_path / "sat12.npy", np.full(SHAPE, 4095, np.uint16))
    out = _run(capsys, tmp_path / "sat12.npy")
    assert out["Pt"]["verdict"] == "not available" and "2^12 - 1" in out["Pt"]["note"]


def test_half_clipped_flat_is_excluded_counted_and_right(tmp_path, capsys):
    dark, flat = _stacks()
    half = flat.copy()
    half[:, :, : SHAPE[2] // 2] = 65535
    np.save(tmp_path / "d.npy", dark)
    np.save(tmp_path / "half.npy", half)
    np.save(tmp_path / "right.npy", flat[:, :, SHAPE[2] // 2:])
    np.save(tmp_path / "dright.npy", dark[:, :, SHAPE[2] // 2:])
    got = _run(capsys, tmp_path / "half.npy", "--dark", tmp_path / "d.npy")
    ref = _run(capsys, tmp_path / "right.npy", "--dark", tmp_path / "dright.npy")
    c = got["_meta"]["clipping"]
    assert c["pixels"] == SHAPE[1] * SHAPE[2] // 2 and c["excluded"]
    for k in ("Pt", "Cs", "G", "o"):
        assert got[k]["verdict"] == ref[k]["verdict"], k
        if ref[k]["value"] is not None:
            assert got[k]["value"] == pytest.approx(ref[k]["value"], rel=1e-6, abs=1e-9), k
        assert "clipped pixels (50 %) excluded" in got[k]["note"], k
    assert abs(got["G"]["value"] - 180.0 ** 2 / 29000) < 4 * got["G"]["se"]  # the truth, not the clip level
    assert main(["analyze", str(tmp_path / "half.npy"), "--dark", str(tmp_path / "d.npy")]) == 0
    assert "CLIPPED: 1536 of 3072 pixels" in capsys.readouterr().out


def test_dark_clipped_at_zero_and_declared_bits(tmp_path, capsys):
    dark, _ = _stacks(1)
    low = dark.astype(np.int32) - 1000 + 3  # offset 3 DN, 5 DN noise: many pixels reach 0
    np.save(tmp_path / "low.npy", np.clip(low, 0, None).astype(np.uint16))
    out = _run(capsys, tmp_path / "low.npy")
    c = out["_meta"]["clipping"]
    assert c["at_zero"] > 0 and c["at_top"] == 0
    assert all(out[k]["verdict"] == "not available" or "clipped pixels" in out[k].get("note", "")
               for k in ("o", "Pt", "Ps"))
    _, flat = _stacks(2)
    np.save(tmp_path / "f.npy", (flat // 16).astype(np.uint16))  # mean ~1875 DN, below a declared 11-bit 2047
    assert _run(capsys, tmp_path / "f.npy")["_meta"]["clipping"]["pixels"] == 0
    out = _run(capsys, tmp_path / "f.npy", "--bits", "10")  # 1023: every pixel above it
    assert out["Pt"]["verdict"] == "not available" and "--bits 10" in out["Pt"]["note"]
