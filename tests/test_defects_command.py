"""``ares defects`` on recorded stacks: output, mask files, one-sentence errors, exit codes."""

import json
import sys

import numpy as np
import pytest
from PIL import Image

from ares.cli import main

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from defect_injection import inject  # noqa: E402


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("defects")
    inj = inject(rows=96, cols=128, frames=100, flat_frames=10, seed=4, bad_columns=1)
    np.save(tmp / "dark_a.npy", inj.dark[:50])
    np.savez(tmp / "dark_b.npz", frames=inj.dark[50:])
    for i in range(3):
        Image.fromarray(inj.flat[i]).save(tmp / f"flat_{i}.png")
    return tmp, inj


def test_json_and_masks(files, capsys):
    tmp, inj = files
    rc = main(["defects", "--dark", str(tmp / "dark_a.npy"), str(tmp / "dark_b.npz"),
               "--flat", *[str(tmp / f"flat_{i}.png") for i in range(3)],
               "--gain", str(inj.gain), "--exposure", str(inj.exposure_s), "--json",
               "--mask-png", str(tmp / "mask.png"), "--mask-h5", str(tmp / "mask.h5")])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["rts"]["available"] is True
    for c in ("hot", "warm", "dead", "stuck", "noisy", "rts"):
        assert out["counts"][c] >= inj.truth[c][0].size * 0.95, (c, out["counts"])
    assert [c["x"] for c in out["bad_columns"]] == inj.truth["bad_columns"].tolist()
    png = np.asarray(Image.open(tmp / "mask.png"))
    assert png.shape == (96, 128) and png.max() > 0
    import h5py
    with h5py.File(tmp / "mask.h5") as f:
        np.testing.assert_array_equal(f["defects/mask"][...], png)


def test_text_and_limit_failure(files, capsys):
    tmp, inj = files
    rc = main(["defects", "--dark", str(tmp / "dark_a.npy"), "--set", "max_hot=0"])
    captured = capsys.readouterr()
    assert rc == 4
    # 50 frames are enough for the RTS test since issue 34 (it needs >= 12)
    assert "hot" in captured.out and "rts: not available" not in captured.out
    assert captured.err.strip() == "ares defects: defect limits failed: hot"


@pytest.mark.parametrize("argv, words", [
    (["--dark", "missing.npy"], ["missing.npy", "not found"]),
    (["--dark", "DARK", "--set", "hot_e_per_second=3"], ["unknown defect parameter"]),
    (["--dark", "DARK", "--exposure", "1", "2"], ["--exposure"]),
])  # (a gain out of range: the parser's, test_analyze_cli.test_physical_options_out_of_range_...)
def test_user_errors_one_sentence_exit_2(files, capsys, argv, words):
    tmp, _ = files
    argv = [str(tmp / "dark_a.npy") if a == "DARK" else a for a in argv]
    rc = main(["defects", *argv])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert err.count("\n") == 0 and "Traceback" not in err
    for w in words:
        assert w in err


def test_bayer_channels(files, capsys):
    tmp, inj = files
    rc = main(["defects", "--dark", str(tmp / "dark_a.npy"), str(tmp / "dark_b.npz"), "--bayer", "--json",
               "--gain", str(inj.gain), "--exposure", str(inj.exposure_s), "--mask-png", str(tmp / "bayer.png")])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(out) == ["00", "01", "10", "11"]
    hot = {(d["y"], d["x"]) for ch in out.values() for d in ch["defects"] if d["class"] == "hot"}
    truth = set(zip(*(a.tolist() for a in inj.truth["hot"])))
    assert len(hot & truth) >= 0.95 * len(truth)
    for name, ch in out.items():
        assert all(d["y"] % 2 == int(name[0]) and d["x"] % 2 == int(name[1]) for d in ch["defects"])
    png = np.asarray(Image.open(tmp / "bayer.png"))
    assert all(png[y, x] & 1 for y, x in hot)


def test_bayer_phases_of_a_one_row_frame_are_one_sentence(tmp_path, capsys):
    """--bayer on frames one row high: phase '10' has no pixel -- one sentence, exit 2."""
    np.save(tmp_path / "one.npy", np.random.default_rng(0).normal(100, 3, (4, 1, 6)).astype(np.uint16))
    assert main(["defects", "--dark", str(tmp_path / "one.npy"), "--bayer"]) == 2
    err = capsys.readouterr().err
    assert "region '10' holds no pixel of a 6x1 frame" in err and err.count("\n") == 1
