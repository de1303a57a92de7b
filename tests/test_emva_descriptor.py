"""EMVA 1288 descriptor reader and replay FrameSource on small generated data sets."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ares.errors import InputError
from ares.hardware.emva_descriptor import EmvaReplaySource, load_level, read_descriptor
from ares.hardware.interfaces import FrameSource


def _png(path, arr):
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(arr.astype(np.uint16)).save(path)


def make_set(tmp_path, levels=4, rows=6, cols=8, bits=12, stack=3, seed=0):
    rng = np.random.default_rng(seed)
    lines = ["# test set", "v 3.0", f"n {bits} {cols} {rows}"]
    for k in range(levels):
        t = 1000.0 * (k + 1)
        lines.append(f"b {t} {100.0 * (k + 1)}")
        for j in range(2):
            name = f"images\\b_{k:03d}_{j}.png"
            _png(tmp_path / "images" / f"b_{k:03d}_{j}.png", rng.poisson(50 * (k + 1), (rows, cols)) + 100)
            lines.append(f"i {name}")
    lines.append("b 2500.0 250.0")
    for j in range(stack):
        _png(tmp_path / "images" / f"bs_{j}.png", rng.poisson(120, (rows, cols)) + 100)
        lines.append(f"i images\\bs_{j}.png")
    for k in range(levels):
        lines.append(f"d {1000.0 * (k + 1)}")
        for j in range(2):
            _png(tmp_path / "images" / f"d_{k:03d}_{j}.png", rng.poisson(3, (rows, cols)) + 100)
            lines.append(f"i images\\d_{k:03d}_{j}.png")
    lines.append("d 2500.0")
    for j in range(stack):
        _png(tmp_path / "images" / f"ds_{j}.png", rng.poisson(3, (rows, cols)) + 100)
        lines.append(f"i images\\ds_{j}.png")
    p = tmp_path / "data.txt"
    p.write_text("\n".join(lines) + "\n")
    return p


def test_reads_levels_and_kinds(tmp_path):
    d = read_descriptor(make_set(tmp_path))
    assert (d.version, d.bits, d.width, d.height) == ("3.0", 12, 8, 6)
    assert len(d.temporal_bright) == 4 and len(d.temporal_dark) == 4
    assert len(d.spatial_bright) == 1 and len(d.spatial_bright[0].images) == 3
    lv = d.temporal_bright[1]
    assert lv.exposure_s == pytest.approx(2e-6) and lv.photons == 200.0
    assert d.dark_for(lv).exposure_ns == lv.exposure_ns and d.dark_for(lv).dark
    stack = load_level(d, lv)
    assert stack.shape == (2, 6, 8) and stack.dtype == np.uint16


def test_replay_source_is_a_frame_source(tmp_path):
    d = read_descriptor(make_set(tmp_path))
    src = EmvaReplaySource(d, d.temporal_bright)
    assert isinstance(src, FrameSource)
    assert src.shape == (6, 8) and src.bit_depth == 12
    src.set_level(2)
    frames = list(src.grab(3))
    assert [f.meta["level"] for f in frames] == [2, 2, 2]
    assert frames[0].meta["photons"] == 300.0 and not frames[0].meta["dark"]
    np.testing.assert_array_equal(frames[0].data, frames[2].data)  # cycles through the pair
    with pytest.raises(InputError):
        src.set_level(9)


@pytest.mark.parametrize("bad, expect", [
    ("b 1000.0", "expected 'b EXPOSURE_NS PHOTONS'"),
    ("b abc 10", "not a number"),
    ("x 1 2", "unknown record type"),
    ("n 12 8", "expected 'n BITS WIDTH HEIGHT'"),
    ("d -5", "non-negative"),
])
def test_bad_record_names_file_and_line(tmp_path, bad, expect):
    p = make_set(tmp_path)
    lines = p.read_text().splitlines()
    lines.insert(3, bad)
    p.write_text("\n".join(lines))
    with pytest.raises(InputError) as ei:
        read_descriptor(p)
    assert f"{p}:4" in str(ei.value) and expect in str(ei.value)


def test_missing_image_and_single_image_level(tmp_path):
    p = make_set(tmp_path)
    text = p.read_text()
    p.write_text(text.replace("images\\b_000_0.png", "images\\nothere.png"))
    with pytest.raises(InputError, match="not found"):
        read_descriptor(p)
    lines = make_set(tmp_path).read_text().splitlines()
    i = lines.index("b 1000.0 100.0")
    del lines[i + 2]
    p.write_text("\n".join(lines))
    with pytest.raises(InputError, match=r":4: a level needs at least two images"):
        read_descriptor(p)


def test_an_image_too_narrow_for_the_declared_bits_is_refused(tmp_path):
    """An 8-bit image in a 12-bit set (truncated, or another camera's): refused naming the
    file, by the command and by the replay source alike; 8-bit data in 16-bit images are fine."""
    from ares.cli import main

    p = make_set(tmp_path)
    Image.fromarray(np.full((6, 8), 100, np.uint8)).save(tmp_path / "images" / "b_001_0.png")
    d = read_descriptor(p)
    with pytest.raises(InputError, match=r"b_001_0.png: the image has 8 bits a pixel, too few for the 12-bit"):
        load_level(d, d.temporal_bright[1])
    src = EmvaReplaySource(d, d.temporal_bright)
    src.set_level(1)
    with pytest.raises(InputError, match="too few for the 12-bit"):
        list(src.grab(1))
    assert main(["emva", str(p)]) == 2
    eight = p.read_text().replace("n 12 8 6", "n 8 8 6")
    p.write_text(eight)
    d = read_descriptor(p)
    stack = load_level(d, d.temporal_bright[1])  # the 8-bit image beside a 16-bit one holding 8-bit values
    assert stack.dtype == np.uint16 and (stack[0] == 100).all() and stack[1].max() < 256


def test_images_outside_the_data_directory_are_refused(tmp_path):
    """A descriptor reads only images below its own directory: a path climbing out of it,
    or a link inside it to a file elsewhere, is refused naming the line (and the link's
    target), before any image is read."""
    data = tmp_path / "set"
    data.mkdir()
    p = make_set(data)
    _png(tmp_path / "outside.png", np.zeros((6, 8)))
    text = p.read_text()
    p.write_text(text.replace("images\\b_000_0.png", "..\\outside.png"))
    with pytest.raises(InputError) as ei:
        read_descriptor(p)
    line = text.splitlines().index("i images\\b_000_0.png") + 1
    assert f"{p}:{line}: references" in str(ei.value) and "outside the data directory" in str(ei.value)
    assert "a link to" not in str(ei.value)
    (data / "images" / "b_000_0.png").unlink()
    (data / "images" / "b_000_0.png").symlink_to(tmp_path / "outside.png")
    p.write_text(text)
    with pytest.raises(InputError) as ei:
        read_descriptor(p)
    assert f"{p}:{line}:" in str(ei.value) and f"(a link to {tmp_path / 'outside.png'})" in str(ei.value)


def test_image_larger_than_declared_bits(tmp_path):
    p = make_set(tmp_path, bits=6)
    d = read_descriptor(p)
    with pytest.raises(InputError, match="exceeds the declared 6 bits"):
        load_level(d, d.temporal_bright[0])


def test_emva_command_on_small_set(tmp_path, capsys):
    from ares.cli import main

    p = make_set(tmp_path, levels=6)
    assert main(["emva", str(p)]) == 0
    out = capsys.readouterr().out
    assert "K" in out and "data:" in out


@pytest.mark.parametrize("release", ["4.0-linear", "4.0-general", "3.1", "3.0"])
def test_a_set_without_photon_counts_gives_verdicts(tmp_path, capsys, release):
    """Photon counts all 0 (a lab that did not calibrate its light): every release still
    answers, exit 0 -- the gain where the data give it, QE and the photon figures "not
    available" with the reason -- and no warning or traceback on stderr."""
    import json
    import re

    from ares.cli import main

    p = make_set(tmp_path, levels=8)
    p.write_text(re.sub(r"^b (\S+) \S+$", r"b \1 0", p.read_text(), flags=re.M))
    assert main(["emva", str(p), "--release", release, "--json", "--pdf", str(tmp_path / "r.pdf")]) == 0
    out, err = capsys.readouterr()
    assert err == "" and (tmp_path / "r.pdf").stat().st_size > 1000
    flat = json.dumps(json.loads(out))
    assert "NaN" not in flat and "Infinity" not in flat
    if release != "4.0-general":
        doc = json.loads(out)
        qe = next(v for k, v in _walk(doc) if k in ("QE", "qe"))
        assert qe["value"] is None and "photon" in qe["note"]


def _walk(doc):
    if isinstance(doc, dict):
        for k, v in doc.items():
            if isinstance(v, dict) and "value" in v:
                yield k, v
            else:
                yield from _walk(v)
    elif isinstance(doc, list):
        for v in doc:
            yield from _walk(v)


def test_a_set_of_constant_images_gives_verdicts(tmp_path, capsys):
    """Every image the same value (a stuck sensor, a test pattern): no gain can be fitted
    -- K "not available" with the reason, exit 0, nothing on stderr."""
    import json

    from ares.cli import main

    p = make_set(tmp_path, levels=8)
    for f in (tmp_path / "images").glob("*.png"):
        _png(f, np.full((6, 8), 300))
    assert main(["emva", str(p), "--json"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    k = next(v for key, v in _walk(json.loads(out)) if key == "K")
    assert k["value"] is None and k["note"]


def test_replay_select_by_exposure_and_light(tmp_path):
    from ares.hardware.emva_descriptor import EmvaReplayLight
    from ares.hardware.interfaces import LightSource

    d = read_descriptor(make_set(tmp_path))
    src = EmvaReplaySource(d)
    light = EmvaReplayLight(src)
    assert isinstance(light, LightSource)
    src.select(exposure_s=3e-6, photons=300.0)
    assert src.level.photons == 300.0 and not src.level.dark
    light.set_level(0)
    assert src.level.dark and src.level.exposure_ns == 3000.0
    frame = next(src.grab(1))
    assert frame.meta["dark"] and frame.meta["exposure_s"] == pytest.approx(3e-6)
    with pytest.raises(InputError, match="no recorded 999 photons/pixel level"):
        light.set_level(999)
