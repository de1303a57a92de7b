"""`ares analyze` on recorded stacks (PNG, .npy, .npz, HDF5) and its errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from ares.cli import main
from ares.hardware.stackfiles import iter_frames, load_stack


def _stack(seed=0, n=6, q=0.0, shape=(24, 32)):
    rng = np.random.default_rng(seed)
    fpn = rng.normal(0, 3, shape)
    x = 200 + fpn + rng.normal(0, 2, (n,) + shape)
    if q:
        x += 0.5 * (q + np.sqrt(q) * rng.standard_normal((n,) + shape))
    return np.round(x).astype(np.uint16)


def test_json_dark_only_npy(tmp_path, capsys):
    x = _stack()
    np.save(tmp_path / "dark.npy", x)
    assert main(["analyze", str(tmp_path / "dark.npy"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for k in ("o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global", "G", "Cg", "Rg", "Pg", "q", "delta"):
        assert set(out[k]) >= {"value", "se", "unit"}
    assert out["Pt"]["unit"] == "DN^2" and "DN^2" in out["_meta"]["units"]
    assert out["G"]["value"] is None and out["G"]["note"] == "dark stack: no gain components"
    assert abs(out["Pt"]["value"] - 4.08) < 0.6  # 2 DN sigma + quantization


def test_table_with_dark_png_and_h5_roi(tmp_path, capsys):
    import h5py

    dark, flat = _stack(1), _stack(2, q=3000.0)
    names = []
    for i, f in enumerate(dark):
        p = tmp_path / f"d_{i:02d}.png"
        Image.fromarray(f).save(p)
        names.append(str(p))
    with h5py.File(tmp_path / "flat.h5", "w") as h:
        h["/run/frames"] = flat
    rc = main(["analyze", f"{tmp_path / 'flat.h5'}:/run/frames", "--dark", *names, "--roi", "2,2,28,20",
               "--illumination", "none"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "20 rows x 28 columns" in text
    assert "stage gain G" in text and "DN/e-" in text
    assert "flat stack frame-global" in text
    g = [line.split() for line in text.splitlines() if line.split()[:1] == ["G"]][0]
    assert g[2] == "±" and abs(float(g[1]) - 0.5) < 0.1


def test_npz_and_folder(tmp_path):
    x = _stack(3, n=4)
    np.savez(tmp_path / "s.npz", a=x[:2], b=x[2:])
    assert load_stack([tmp_path / "s.npz"]).shape == (4, 24, 32)
    assert load_stack([f"{tmp_path / 's.npz'}:b"]).shape == (2, 24, 32)
    d = tmp_path / "imgs"
    d.mkdir()
    for i, f in enumerate(x):
        Image.fromarray(f).save(d / f"{i}.tif")
    np.testing.assert_array_equal(load_stack([d]), x)


@pytest.mark.parametrize(
    "make,msg",
    [
        (lambda p: None, "file not found"),
        (lambda p: (p / "bad.png").write_bytes(b"not a png"), "not a readable image"),
        (lambda p: (p / "bad.npy").write_bytes(b"garbage"), "not a readable .npy"),
        (lambda p: np.save(p / "bad.npy", np.zeros(5)), "expected a 2-D frame"),
    ],
)
def test_missing_or_corrupt_files_one_sentence(tmp_path, capsys, make, msg):
    make(tmp_path)
    target = {"file not found": "missing.png", "not a readable image": "bad.png"}.get(msg, "bad.npy")
    rc = main(["analyze", str(tmp_path / target)])
    err = capsys.readouterr().err
    assert rc == 2
    assert msg in err and err.count("\n") == 1 and "Traceback" not in err


def test_an_8_bit_image_among_16_bit_ones_is_refused(tmp_path, capsys):
    """A folder's odd file out (an 8-bit export beside the camera's 16-bit frames) stops
    the analysis naming it, instead of entering the stack as a frame 10x darker."""
    rng = np.random.default_rng(0)
    for i in range(3):
        Image.fromarray(rng.normal(1000, 10, (8, 9)).astype(np.uint16)).save(tmp_path / f"f{i}.png")
    Image.fromarray(rng.normal(100, 3, (8, 9)).astype(np.uint8)).save(tmp_path / "f3.png")
    assert main(["analyze", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 'f3.png'}: uint8 data among the uint16 frames of {tmp_path / 'f0.png'}" in err
    assert err.count("\n") == 1


def test_shape_mismatch_and_bad_roi(tmp_path, capsys):
    np.save(tmp_path / "a.npy", _stack(shape=(8, 8)))
    np.save(tmp_path / "b.npy", _stack(shape=(8, 9)))
    assert main(["analyze", str(tmp_path / "a.npy"), str(tmp_path / "b.npy")]) == 2
    assert "differs" in capsys.readouterr().err
    assert main(["analyze", str(tmp_path / "a.npy"), "--roi", "4,4,10,10"]) == 2
    assert "outside" in capsys.readouterr().err
    with pytest.raises(Exception):
        list(iter_frames([]))


@pytest.mark.parametrize("argv, fragment", [
    (["analyze", "x.npy", "--gain", "0"], "argument --gain: must be a finite number > 0, got '0'"),
    (["analyze", "x.npy", "--gain", "nan"], "argument --gain: must be a finite number, got 'nan'"),
    (["analyze", "x.npy", "--gain", "1e300DN/e-"], "a gain of 1e+300 DN/e- is beyond any sensor's"),
    (["analyze", "x.npy", "--gain", "70"], "a bare gain of 70 is outside 0.001-50 DN/e- (sensors' range): "
                                           "a conversion gain is written 70uV/e- (with --adc-lsb-uv)"),
    (["analyze", "x.npy", "--gain", "70 mV"], "unknown gain unit 'mV'"),
    (["defects", "--dark", "x.npy", "--gain", "-0.3"], "argument --gain: must be a finite number > 0"),
    (["defects", "--dark", "x.npy", "--exposure", "-1"], "argument --exposure: must be a finite number >= 0"),
    (["emva", "d.txt", "--pixel-size-um", "inf"], "argument --pixel-size-um: must be a finite number"),
    (["ptc", "t.csv", "--adc-lsb-uv", "abc"], "argument --adc-lsb-uv: 'abc' is not a number"),
])
def test_physical_options_out_of_range_are_refused_by_the_parser(capsys, argv, fragment):
    """A gain of 0 or 1e300, a negative exposure ...: one sentence naming the option and
    exit 2 before any file is read (the analysis would divide by them)."""
    with pytest.raises(SystemExit) as ei:
        main(argv)
    assert ei.value.code == 2
    assert fragment in capsys.readouterr().err


def test_fuzzed_stacks_end_in_a_result_or_one_sentence(tmp_path, capsys):
    """Odd stacks (constant, one row or column, one pixel, NaN, 1e303, negative floats,
    bool, uint32 at full scale), with and without a dark, in text and JSON: exit 0 or 2
    with one sentence, never an exception or a numpy warning (errors here)."""
    import random
    import warnings

    rnd, rng = random.Random(3), np.random.default_rng(3)
    kinds = ["const", "nan", "huge", "neg", "one_px", "row1", "col1", "two_frames", "bool", "uint32max", "plain"]
    for trial, kind in enumerate(kinds * 2):
        n, r, c = rnd.choice([2, 3, 8]), rnd.choice([2, 5, 16]), rnd.choice([2, 7, 16])
        a = rng.normal(1000, 5, (n, r, c))
        a = {"const": np.full(a.shape, 7.0), "huge": a * 1e300, "neg": a - 5000, "one_px": a[:, :1, :1],
             "row1": a[:, :1, :], "col1": a[:, :, :1], "two_frames": a[:2], "bool": a > 1000,
             "uint32max": np.full(a.shape, 2**32 - 1, np.uint32)}.get(kind, a)
        if kind == "nan":
            a.flat[rnd.randrange(a.size)] = np.nan
        if kind in ("const", "one_px", "row1", "col1", "two_frames", "plain"):
            a = a.astype(np.uint16)
        np.save(tmp_path / "f.npy", a)
        np.save(tmp_path / "d.npy", rng.normal(100, 2, a.shape).astype(np.uint16))
        dark = ["--dark", str(tmp_path / "d.npy")] if trial % 2 else []
        for extra in ([], ["--json"]):
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                rc = main(["analyze", str(tmp_path / "f.npy"), *dark, *extra])
            err = capsys.readouterr().err
            assert rc in (0, 2) and (rc == 0) == (err == "") and err.count("\n") <= 1, (kind, dark, err)
