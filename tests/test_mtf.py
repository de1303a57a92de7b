"""Slanted-edge MTF (ISO 12233 e-SFR, ares.analysis.optics.mtf) against the simulator's closed-form
truth (ares.sim.edge), against an independent implementation of the standard's steps written
here, and its verdicts."""

import math

import numpy as np
import pytest

from ares.analysis.optics.mtf import sfr, sfr_channels
from ares.sim.edge import edge_map, true_mtf, true_mtf50
from ares.sim.params import SensorParams
from ares.sim.sensor import SimSensor

SIGMA = 0.6
# bright side ~4000 e-: its shot noise ~63 e-, the edge step (75 %) ~48x that (SNR ~50)
FLUX = 4000 / (0.01 * 0.6)


def _edge_sensor(angle, seed=3, cols=64, **kw):
    p = SensorParams(rows=200, cols=cols, illumination="slanted_edge", edge_angle_deg=angle,
                     edge_psf_sigma_px=SIGMA, **kw).without_defects()
    return SimSensor(p, seed=seed)


def _stack_mean(s, n=4):
    return s.render(n, exposure_s=0.01, photon_flux=FLUX).astype(np.float64).mean(axis=0)


def independent_sfr(img):
    """MTF50 (cycles/pixel along the edge normal) by ISO 12233:2017 e-SFR written here from the
    standard's step list, row by row, without ares.analysis.optics.mtf's code:
    1. per row, the [-1/2, +1/2] derivative's centroid under a Hamming window centred on the
       row's middle; a least-squares line through them; again with each row's window centred
       on that line;
    2. the first round(floor(rows |slope|) / |slope|) rows;
    3. each pixel's x offset from the line, in quarter-pixel bins, 4 x columns of them centred
       on the edge, each bin's mean (empty bins: linear interpolation);
    4. the [-1/2, 0, +1/2] derivative; the LSF shifted so its centroid sits in the middle, a
       symmetric Hamming window over the whole array;
    5. |DFT| / DFT at 0, divided by the FIR's response sin(2 pi k/n) / (2 pi k/n);
    6. frequency k / (n / 4) / cos(angle); the first crossing of 0.5, linear interpolation."""
    R, C = img.shape
    sign = 1.0 if img[:, -3:].sum() > img[:, :3].sum() else -1.0
    pos = np.arange(C - 1) + 0.5  # where each derivative sample sits

    def hamming(centre):
        half = max(centre - pos[0], pos[-1] - centre)
        return 0.54 + 0.46 * np.cos(np.pi * (pos - centre) / half)

    def locate(centres):
        locs = []
        for r in range(R):
            der = sign * np.convolve(img[r], [0.5, -0.5], mode="valid") * hamming(centres[r])
            locs.append(float(np.dot(der, pos) / der.sum()))
        return np.polyfit(np.arange(R), locs, 1)

    slope, icpt = locate([(C - 1) / 2.0] * R)
    slope, icpt = locate(icpt + slope * np.arange(R))
    rows = int(round(math.floor(R * abs(slope)) / abs(slope)))
    n = 4 * C
    sums, counts = np.zeros(n), np.zeros(n)
    for r in range(rows):
        for c in range(C):
            j = int(math.floor((c - (icpt + slope * r)) * 4)) + n // 2
            if 0 <= j < n:
                sums[j] += img[r, c]
                counts[j] += 1
    full = counts > 0
    esf = np.interp(np.arange(n), np.flatnonzero(full), sums[full] / counts[full])
    lsf = np.convolve(esf, [0.5, 0.0, -0.5], mode="same")
    lsf[0], lsf[-1] = lsf[1], lsf[-2]
    lsf *= np.sign(lsf.sum())
    shift = n // 2 - int(round(np.dot(lsf, np.arange(n)) / lsf.sum()))
    moved = np.zeros(n)
    if shift >= 0:
        moved[shift:] = lsf[:n - shift]
    else:
        moved[:n + shift] = lsf[-shift:]
    moved *= np.hamming(n)
    k = np.arange(n // 2 + 1)
    dft = np.abs(np.exp(-2j * np.pi * np.outer(k, np.arange(n)) / n) @ moved)
    x = 2 * np.pi * k[1:] / n
    mtf = dft / dft[0]
    mtf[1:] *= x / np.sin(x)
    f = k / (n / 4.0) / math.cos(math.atan(slope))
    i = int(np.nonzero(mtf < 0.5)[0][0])
    return f[i - 1] + (mtf[i - 1] - 0.5) * (f[i] - f[i - 1]) / (mtf[i - 1] - mtf[i])


def test_edge_map_is_the_pixel_integral_of_the_blurred_step():
    """The exact pixel means against a brute-force 64x64 supersampled integral."""
    ang, sig = 7.0, 0.6
    m = edge_map(8, 8, ang, sig, low=0.0)
    th = math.radians(ang)
    from scipy.special import ndtr
    u = (np.arange(64) + 0.5) / 64 - 0.5
    for r, c in [(3, 3), (4, 3), (4, 4), (2, 4)]:
        yy, xx = np.meshgrid(r + u, c + u, indexing="ij")
        d = (xx - 3.5) * math.cos(th) - (yy - 3.5) * math.sin(th)
        assert m[r, c] == pytest.approx(ndtr(d / sig).mean(), abs=2e-4)


@pytest.mark.parametrize("angle", [2.0, 4.0, 6.0, 8.0, 10.0])
def test_mtf50_within_2pct_of_closed_form_at_snr50(angle):
    """The configuration benchmarks/beyond_linear.md finds within 2 % at SNR 50 (edge step /
    shot noise 48 per frame): scans/mtf.xml's, the mean of 8 frames of 200x128 pixels, with the
    option esf_half_width=16 (worst 1.3 % over 20 seeds per angle there); the standard's
    whole-region result (worst 2.5 % there) within 4 of its SEs plus its noise-free binning
    bias (-0.5 %)."""
    from ares.analysis.optics.mtf import LOW_NOISE_HALF_WIDTH

    s = _edge_sensor(angle, cols=128)
    img = _stack_mean(s, 8)
    r = sfr(img, max_code=4095, bootstrap=20)
    o = sfr(img, max_code=4095, bootstrap=20, esf_half_width=LOW_NOISE_HALF_WIDTH)
    truth = true_mtf50(angle, SIGMA, s.params.crosstalk_pct)
    assert r.angle_deg.value == pytest.approx(angle, abs=0.05)
    assert o.mtf50.available and abs(o.mtf50.value / truth - 1) < 0.02
    assert abs(o.mtf50.value - truth) < 4 * o.mtf50.se  # the SE covers the error
    assert r.mtf50.available and abs(r.mtf50.value - truth) < 4 * r.mtf50.se + 0.005 * truth
    nyq = float(true_mtf(0.5, angle, SIGMA, s.params.crosstalk_pct))
    assert abs(r.mtf_nyquist.value - nyq) < 4 * r.mtf_nyquist.se  # the SE covers the error (SE ~0.011)


@pytest.mark.parametrize("angle", [2.0, 6.0, 10.0])
def test_mtf50_within_1pct_of_an_independent_implementation(angle):
    """One frame at SNR 50, as the issue asks (the noise goes through both the same way)."""
    img = _stack_mean(_edge_sensor(angle, seed=5), 1)
    mine = sfr(img, bootstrap=0).mtf50.value
    assert abs(mine / independent_sfr(img) - 1) < 0.01


def test_low_noise_option_beside_the_standard():
    """esf_half_width keeps 16 px of the ESF either side: less noise, the same MTF50 within
    its SE, and a smaller SE than the standard's whole-region ESF on the same image (60
    re-noised copies: 20 do not resolve the ~12 % smaller SE on this image, the SEs' ratio
    came out 1.01 at 20 copies, 0.88 at 60, 0.89 at 200)."""
    from ares.analysis.optics.mtf import LOW_NOISE_HALF_WIDTH

    s = _edge_sensor(6.0, seed=7)
    img = _stack_mean(s, 1)
    std = sfr(img, bootstrap=60)
    opt = sfr(img, bootstrap=60, esf_half_width=LOW_NOISE_HALF_WIDTH)
    truth = true_mtf50(6.0, SIGMA, s.params.crosstalk_pct)
    assert abs(opt.mtf50.value / truth - 1) < 0.02 and abs(opt.mtf50.value - truth) < 4 * opt.mtf50.se
    assert opt.mtf50.se < std.mtf50.se


def test_verdicts():
    flat_angle = edge_map(120, 64, 0.5, SIGMA) * 1000
    assert "outside 2-22" in sfr(flat_angle).mtf50.note
    steep = edge_map(64, 200, 30.0, SIGMA) * 1000
    assert "outside 2-22" in sfr(steep).mtf50.note
    rng = np.random.default_rng(0)
    faint = edge_map(120, 64, 5.0, SIGMA) * 100 + rng.normal(0, 15, (120, 64))
    assert sfr(faint).mtf50.note.startswith("too little contrast")
    clipped = np.minimum(edge_map(120, 64, 5.0, SIGMA) * 5000, 4095)
    assert sfr(clipped, max_code=4095).mtf50.note.startswith("clipping")
    ok = sfr(edge_map(120, 64, 5.0, SIGMA) * 1000 + rng.normal(0, 5, (120, 64)), max_code=4095)
    assert ok.mtf50.available and ok.mtf50.se > 0


def test_horizontal_edge_is_transposed():
    img = edge_map(64, 200, 5.0, SIGMA).T.copy() * 1000
    assert sfr(img, bootstrap=0).mtf50.value == pytest.approx(true_mtf50(5.0, SIGMA), rel=0.01)


def test_bayer_channels_each_see_the_optics():
    """Each channel of an RGGB mosaic (its own pixels at twice the pitch) gives the same MTF50
    in cycles per sensor pixel, within 3 %; Nyquist is 0.25 cycles per sensor pixel."""
    p = SensorParams(rows=240, cols=96, illumination="slanted_edge", edge_angle_deg=5.0, edge_psf_sigma_px=1.2,
                     cfa="RGGB", cfa_response=(0.6, 1.0, 1.0, 0.8), crosstalk_pct=0.0).without_defects()
    img = SimSensor(p, seed=2).render(4, exposure_s=0.01, photon_flux=FLUX).astype(float).mean(axis=0)
    res = sfr_channels(img, "RGGB", bootstrap=0)
    assert sorted(res) == ["B", "Gb", "Gr", "R"]
    truth = _channel_mtf50(5.0, 1.2)
    for name, r in res.items():
        assert r.nyquist == 0.25
        assert r.mtf50.value == pytest.approx(truth, rel=0.03), name


def _channel_mtf50(angle, sigma):
    """One channel of a mosaic samples the blurred edge at a 2-pixel pitch with a 1-pixel
    aperture: the optics' and the pixel's MTF50, per sensor pixel."""
    from scipy.optimize import brentq

    th = math.radians(angle)
    return brentq(lambda f: math.exp(-2 * math.pi ** 2 * sigma ** 2 * f * f)
                  * abs(np.sinc(f * math.cos(th)) * np.sinc(f * math.sin(th))) - 0.5, 1e-4, 0.5)


def test_mtf_command_on_raw_bayer_png_and_tiff(tmp_path, capsys):
    """A user's raw RGGB frames as 16-bit PNG and TIFF files: ``ares mtf --bayer RGGB``
    averages them and gives each channel's MTF50 within 3 % of the truth."""
    import json

    from PIL import Image

    from ares.cli import main

    p = SensorParams(rows=240, cols=96, illumination="slanted_edge", edge_angle_deg=5.0, edge_psf_sigma_px=1.2,
                     cfa="RGGB", cfa_response=(0.6, 1.0, 1.0, 0.8), crosstalk_pct=0.0).without_defects()
    frames = SimSensor(p, seed=4).render(4, exposure_s=0.01, photon_flux=FLUX)
    files = []
    for i, f in enumerate(frames):
        files.append(tmp_path / f"edge{i}.{'png' if i % 2 else 'tif'}")
        Image.fromarray(f.astype(np.uint16)).save(files[-1])
    assert main(["mtf", *map(str, files), "--bayer", "RGGB", "--bits", "12", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["frames"] == 4 and sorted(out["channels"]) == ["B", "Gb", "Gr", "R"]
    for name, d in out["channels"].items():
        assert d["nyquist_cy_per_px"] == 0.25
        assert d["mtf50_cy_per_px"]["value"] == pytest.approx(_channel_mtf50(5.0, 1.2), rel=0.03), name


def test_mtf_command(tmp_path, capsys):
    import json

    from ares.cli import main

    rng = np.random.default_rng(0)
    f = tmp_path / "edge.npy"
    np.save(f, (edge_map(200, 64, 5.0, SIGMA) * 2000 + 100 + rng.normal(0, 20, (200, 64))).astype(np.uint16))
    assert main(["mtf", str(f), "--bits", "12", "--json", "--pdf", str(tmp_path / "m.pdf")]) == 0
    d = json.loads(capsys.readouterr().out)["channels"]["mono"]
    assert d["mtf50_cy_per_px"]["value"] == pytest.approx(true_mtf50(5.0, SIGMA), rel=0.02)
    assert (tmp_path / "m.pdf").stat().st_size > 1000
    assert main(["mtf", str(f), "--roi", "1,2,3"]) != 0
    assert "X,Y,W,H" in capsys.readouterr().err


def test_mtf_command_option_beside_the_standard(tmp_path, capsys):
    """--esf-half-width adds the option's figures, labelled, beside the standard's (the same
    standard figures as without it); a half-width under 4 px is refused in one sentence."""
    import json

    from ares.cli import main

    rng = np.random.default_rng(1)
    f = tmp_path / "edge.npy"
    np.save(f, (edge_map(200, 64, 5.0, SIGMA) * 2000 + 100 + rng.normal(0, 20, (200, 64))).astype(np.uint16))
    assert main(["mtf", str(f), "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)["channels"]["mono"]
    assert main(["mtf", str(f), "--json", "--esf-half-width", "16", "--pdf", str(tmp_path / "o.pdf")]) == 0
    d = json.loads(capsys.readouterr().out)["channels"]["mono"]
    assert d["mtf50_cy_per_px"] == plain["mtf50_cy_per_px"] and "option" not in plain
    assert d["option"]["esf_half_width"] == 16
    assert d["option"]["mtf50_cy_per_px"]["value"] == pytest.approx(true_mtf50(5.0, SIGMA), rel=0.02)
    assert main(["mtf", str(f), "--esf-half-width", "16"]) == 0
    text = capsys.readouterr().out
    assert "mono: MTF50" in text and "mono, option esf_half_width=16 px (not the standard): MTF50" in text
    assert main(["mtf", str(f), "--esf-half-width", "2"]) != 0
    assert "--esf-half-width 2: give a number of pixels of at least 4" in capsys.readouterr().err
