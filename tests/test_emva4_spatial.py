"""EMVA 1288 Release 4.0 Linear, Sections 4.2 - 4.4, 7 and 8, against hand computations:
small synthetic images whose answer is known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ares.analysis.emva import graphs
from ares.analysis.emva.sheet import dark_current_4
from ares.analysis.ptc.levels import pair_step
from ares.analysis.stats.splines import beta3, beta3_prime, bspline_fit
from ares.analysis.spatial.nonuniformity import dsnu, highpass, prnu, smooth, split, white_gains
from ares.analysis.stats.estimate import Estimate
from ares.analysis.ptc.levels import stack_moments

M, N = 96, 128


def test_highpass_kernel_and_border():
    """Section 8.1: 7x7 box, 11x11 box, 3x3 binomial, one after the other; a delta image
    gives the kernel (19 x 19, sum 1, separable); 9 border rows/columns are dropped."""
    img = np.zeros((41, 41))
    img[20, 20] = 1.0
    k1 = np.convolve(np.convolve(np.ones(7) / 7, np.ones(11) / 11), [0.25, 0.5, 0.25])
    sm = smooth(img)
    assert sm.shape == (23, 23)
    np.testing.assert_allclose(sm[11 - 9:11 + 10, 11 - 9:11 + 10], np.outer(k1, k1), atol=1e-9)
    assert highpass(np.ones((40, 50)) * 7).shape == (22, 32)
    # a plane (illumination gradient) and a constant are removed exactly
    y, x = np.mgrid[:M, :N]
    np.testing.assert_allclose(highpass(100 + 0.3 * x - 0.2 * y), 0, atol=2e-5)  # float32 passes
    # a quadratic (vignetting) leaves only a constant, which the variances remove
    hp = highpass(1000 - 0.01 * ((x - N / 2) ** 2 + (y - M / 2) ** 2))
    assert np.ptp(hp) < 1e-4
    with pytest.raises(ValueError, match="more than 20"):
        highpass(np.ones((20, 50)))


def _scipy_passes(img, release, border):
    """The definition, as scipy.ndimage passes: float64, reflected borders at every pass."""
    from scipy import ndimage

    x = np.asarray(img, np.float64)
    m = x.mean()
    x = x - m
    for ax in (0, 1):
        if release == "4.0":
            x = ndimage.uniform_filter1d(x, 7, axis=ax, mode="reflect")
            x = ndimage.uniform_filter1d(x, 11, axis=ax, mode="reflect")
            x = ndimage.correlate1d(x, [0.25, 0.5, 0.25], axis=ax, mode="reflect")
        else:
            x = ndimage.uniform_filter1d(x, 5, axis=ax, mode="reflect")
    if border == "valid":
        b = {"4.0": 9, "3.1": 2}[release]
        x = x[b:-b, b:-b]
    return x + m


@pytest.mark.parametrize("release", ["4.0", "3.1"])
@pytest.mark.parametrize("border,shape", [("valid", (480, 640)), ("valid", (21, 23)), ("valid", (25, 300)),
                                          ("reflect", (480, 640)), ("reflect", (21, 23)), ("reflect", (25, 300)),
                                          ("reflect", (7, 9))])
@pytest.mark.parametrize("path", ["numba", "numpy float", "numpy integer"])
def test_every_lowpass_path_equals_the_scipy_passes(monkeypatch, release, border, shape, path):
    """The numba kernel (``ares.analysis.kernels.lowpass``, float64), the numpy path (binary-doubling
    box sums, float64 on the centred image) and the exact integer path all equal the
    scipy.ndimage passes within float64 rounding, borders included (images smaller than
    the filters: repeated reflection)."""
    import ares.analysis.kernels.lowpass as lp

    rng = np.random.default_rng(7)
    img = rng.normal(1000, 10, shape) + np.linspace(0, 80, shape[1])[None, :] + (rng.random(shape) < 0.01) * 500
    if path == "numpy integer":
        img = np.rint(img).astype(np.uint16)
    elif path == "numpy float":
        monkeypatch.setattr(lp, "_kernel_c", None)
        monkeypatch.setattr(lp, "_loaded", True)
    got = smooth(img, release, border)
    if path == "numba" and lp._kernel_c is None:
        pytest.skip("numba not available")
    ref = _scipy_passes(img, release, border)
    assert got.shape == ref.shape
    scale = float(np.abs(img - img.mean()).max())
    np.testing.assert_allclose(got, ref, rtol=0, atol=64 * scale * 2.0**-53)


@pytest.mark.parametrize("release,b", [("4.0", 9), ("3.1", 2)])
@pytest.mark.parametrize("dtype,hi", [(np.int32, 2**14), (np.uint16, 2**16), (np.int64, 2**31)])
def test_integer_images_are_highpassed_exactly(release, b, dtype, hi):
    """An integer image (a pair's sum) is filtered in integers: W x - S equals the exact
    integer convolution, and the only rounding is the division by the weight W (int32 work
    when W times the range fits, int64 otherwise)."""
    rng = np.random.default_rng(3)
    img = rng.integers(0, hi, (40, 47)).astype(dtype)
    img[3, 5] = hi - 1
    k = (np.convolve(np.convolve(np.ones(7, np.int64), np.ones(11, np.int64)), [1, 2, 1]) if release == "4.0"
         else np.ones(5, np.int64))
    W = int(k.sum()) ** 2
    x = img.astype(object)  # Python integers: no rounding anywhere
    rows = np.array([[sum(int(k[t]) * x[i + t, j] for t in range(k.size)) for j in range(x.shape[1])]
                     for i in range(x.shape[0] - k.size + 1)], dtype=object)
    S = np.array([[sum(int(k[t]) * rows[i, j + t] for t in range(k.size)) for j in range(x.shape[1] - k.size + 1)]
                  for i in range(rows.shape[0])], dtype=object)
    exact = (W * x[b:-b, b:-b] - S).astype(np.float64) * (1.0 / W)
    assert np.array_equal(highpass(img, release), exact)


def test_a_pair_split_from_its_integer_sum_equals_the_float_average():
    """``split`` of a pair's exact sum with scale 1/2 (what ``pair_step`` does) against the
    split of the float64 average image: the same variances within float64 rounding."""
    rng = np.random.default_rng(11)
    a = rng.integers(100, 4000, (M, N)).astype(np.uint16)
    b = rng.integers(100, 4000, (M, N)).astype(np.uint16)
    s_int = split(np.add(a, b, dtype=np.int32), 30.0, 2, "4.0", 0.1, 0.2, scale=0.5)
    s_avg = split((a.astype(np.float64) + b) / 2, 30.0, 2, "4.0", 0.1, 0.2)
    for k in ("total", "col", "row", "pix", "mean", "se_total"):
        assert getattr(s_int, k) == pytest.approx(getattr(s_avg, k), rel=1e-12), k


def test_white_noise_gains():
    """sum h^2 of the high-pass: 2-D ~0.988 for 4.0, 0.96 for 3.1 (Appendix C.5: 1 - 2/25 + 1/25)."""
    g1, g2 = white_gains("3.1")
    assert g2 == pytest.approx(1 - 2 / 25 + 1 / 25)
    assert g1 == pytest.approx(1 - 2 / 5 + 1 / 5)
    g1, g2 = white_gains("4.0")
    assert 0.85 < g1 < 0.9 and 0.985 < g2 < 0.99
    assert white_gains("none") == (1.0, 1.0)


@pytest.mark.parametrize("kind", ["row", "col"])
def test_pure_line_pattern_gives_only_its_own_variance(kind):
    """Eqs. 41 - 44 without the high-pass: a pure row pattern gives only s2_row (= its
    variance, 1/M normalisation), likewise a column pattern; exact to rounding."""
    rng = np.random.default_rng(101)  # per test: independent of the test order
    if kind == "row":
        v = rng.normal(0, 2, M)
        img = 50 + v[:, None] + np.zeros((M, N))
    else:
        v = rng.normal(0, 2, N)
        img = 50 + v[None, :] + np.zeros((M, N))
    s = split(img, 0.0, 1, "none")
    want = float(np.var(v))
    for part in ("row", "col", "pix"):
        assert getattr(s, part) == pytest.approx(want if part == kind else 0.0, abs=1e-9 * want)
    assert s.total == pytest.approx(float(np.var(img)))


def test_split_is_eq_44_by_hand():
    """A mixed pattern: the three parts are Eq. 44 computed by hand from s2, s2_cav, s2_rav
    (Eq. 41) with the temporal terms; a white pixel pattern lands in s2_pix."""
    rng = np.random.default_rng(102)  # per test: independent of the test order
    img = 7 + rng.normal(0, 1, M)[:, None] + rng.normal(0, 0.5, N)[None, :] + rng.normal(0, 2, (M, N))
    t, L = 3.0, 10
    s = split(img, t, L, "none")
    s2 = float(np.var(img)) - t / L
    cav = float(np.var(img.mean(axis=0))) - t / (L * M)
    rav = float(np.var(img.mean(axis=1))) - t / (L * N)
    d = M * N - M - N
    assert s.col == pytest.approx((M * N - M) / d * cav - N / d * (s2 - rav), rel=1e-9)
    assert s.row == pytest.approx((M * N - N) / d * rav - M / d * (s2 - cav), rel=1e-9)
    assert s.pix == pytest.approx(M * N / d * (s2 - cav - rav), rel=1e-9)
    # no temporal noise was added: the pixel pattern's population variance 4 less the t / L
    # claimed, within the pattern's own sampling spread (s.se_pix is the measurement error of
    # THIS pattern, ``pattern_se``: not this comparison's)
    assert s.pix == pytest.approx(4.0 - t / L, abs=3 * math.sqrt(2 / (M * N)) * 4.0)
    assert s.row == pytest.approx(1.0, rel=0.3) and s.col == pytest.approx(0.25, rel=0.4)


def test_two_images_give_eq_32():
    """Eq. 32: the spatial variance from two images is (1/NM) sum (y0 - mu0)(y1 - mu1); the
    L = 2 split of their average with the Eq. 18 variance gives it exactly."""
    rng = np.random.default_rng(103)  # per test: independent of the test order
    pattern = rng.normal(0, 3, (M, N))
    a = np.round(100 + pattern + rng.normal(0, 2, (M, N)) + 0.7)  # frame offsets differ
    b = np.round(100 + pattern + rng.normal(0, 2, (M, N)))
    eq32 = float(np.mean((a - a.mean()) * (b - b.mean())))
    st = pair_step(a.astype(np.uint16), b.astype(np.uint16), 4095)
    s = split((a + b) / 2, st[1].var, 2, "none")
    assert s.total == pytest.approx(eq32, rel=1e-10)


def test_temporal_residual_is_removed_and_line_noise_not_taken_for_a_pattern():
    """A stack of pure temporal noise (no pattern at all) with row-correlated temporal noise:
    the split of its average is ~0 in every part under option rowcol_corrected
    (``Split.extended``, the measured row/column temporal variances of stack_moments given),
    while the white-noise assumption of Eqs. 39 - 41 as written (the split itself, whether
    or not they are given) reports the row noise / L as a row pattern."""
    rng = np.random.default_rng(104)  # per test: independent of the test order
    L = 40
    frames = [np.round(500 + rng.normal(0, 2, (M, N)) + rng.normal(0, 1.5, (M, 1))).astype(np.uint16)
              for _ in range(L)]
    st, avg, line, _ = stack_moments(frames)
    given = split(avg, line.pixel, L, "none", line.rows, line.cols)
    good = given.extended
    naive = split(avg, st.s2_temporal, L, "none")
    assert given.row == pytest.approx(split(avg, line.pixel, L, "none").row, rel=1e-12)  # the text by default
    for part in ("row", "col", "pix"):
        v, se = good.get(part)
        assert abs(v) < 3 * se + 1e-3, (part, v, se)
    assert naive.row > 5 * naive.se_row  # 1.5^2 / 40 left as a "row pattern"
    assert naive.row == pytest.approx(1.5**2 / L, rel=0.35)


def test_dsnu_prnu_closed_form():
    """Eqs. 66/67 from known variances: DSNU = s_dark / K; PRNU = sqrt(s2_50 - s2_dark) /
    (mu_50 - mu_dark); a variance within 2 SE of zero is an upper limit."""
    rng = np.random.default_rng(105)  # per test: independent of the test order
    dark = 10 + rng.normal(0, 1.0, (M, N))
    gainmap = 1 + rng.normal(0, 0.01, (M, N))
    bright = dark + 2000 * gainmap
    K = 0.5
    ds = split(dark, 0.0, 1000, "none")
    bs = split(bright, 0.0, 1000, "none")
    d = dsnu(ds, K, 0.0)
    assert d["DSNU1288"].value == pytest.approx(math.sqrt(ds.total) / K)
    assert d["DSNU1288_pix"].value == pytest.approx(math.sqrt(ds.pix) / K)
    p = prnu(bs, ds)
    assert p["PRNU1288"].value == pytest.approx(100 * math.sqrt(bs.total - ds.total) / (bs.mean - ds.mean))
    assert p["PRNU1288"].value == pytest.approx(100 * np.std(2000 * gainmap) / 2000, rel=0.02)
    flat = split(np.full((M, N), 5.0) + rng.normal(0, 1e-3, (M, N)), 1.0, 100, "none")
    lim = dsnu(flat, K, 0.0)["DSNU1288"]
    assert lim.bound == "upper" and lim.value > 0


def test_spectrogram_white_flat_and_periodic_peak():
    """Eq. 71: white noise is flat at its variance; a column pattern a*cos(2 pi n f) puts a
    peak at f whose Eq. 72 amplitude is a."""
    rng = np.random.default_rng(106)  # per test: independent of the test order
    w = rng.normal(0, 2.0, (256, 256))
    sp = graphs.spectrogram(w, "horizontal")
    assert np.mean(sp.sqrt_power[1:] ** 2) == pytest.approx(4.0, rel=0.02)
    n = np.arange(256)
    img = 3.0 * np.cos(2 * np.pi * n * 32 / 256)[None, :] + np.zeros((64, 256))
    sp = graphs.spectrogram(img, "horizontal")
    assert sp.freq[np.argmax(sp.sqrt_power)] == pytest.approx(0.125)
    power = np.concatenate([sp.sqrt_power**2, (sp.sqrt_power**2)[-2:0:-1]])  # full 0..N-1 spectrum
    assert graphs.pattern_amplitude(power, 256, 32, 32) == pytest.approx(3.0, rel=1e-9)
    v = graphs.spectrogram(img.T, "vertical")
    np.testing.assert_allclose(v.sqrt_power, sp.sqrt_power)


def test_profiles_middle_mean_max_min():
    img = np.arange(5 * 4, dtype=float).reshape(5, 4)
    p = graphs.profiles(img, "horizontal")
    np.testing.assert_array_equal(p["middle"], img[2])  # row M // 2
    np.testing.assert_array_equal(p["max"], img[4])
    np.testing.assert_array_equal(p["min"], img[0])
    q = graphs.profiles(img, "vertical")
    np.testing.assert_array_equal(q["middle"], img[:, 2])
    assert graphs.profile_range(p, "dsnu") == pytest.approx((0.9 * img[0].mean(), 1.1 * img[4].mean()))


def test_log_histogram_bins_are_multiples_of_1_over_L_and_show_a_single_outlier():
    """Eqs. 73 - 76: bin width I/L with I = floor(L (ymax - ymin) / 256) + 1, at most 256
    bins, every pixel counted; one outlier pixel appears as a bin of 1."""
    rng = np.random.default_rng(107)  # per test: independent of the test order
    L = 50
    img = np.round(rng.normal(100, 1, (M, N)) * L) / L
    img[3, 3] = 130.0
    h = graphs.log_histogram(img, L)
    I = math.floor(L * (img.max() - img.min()) / 256) + 1
    assert h.width == pytest.approx(I / L)
    assert h.counts.size <= 256 and h.counts.sum() == img.size
    assert h.counts[-1] == 1
    assert h.model.sum() == pytest.approx(img.size, rel=0.05)  # the normal density integrates to N M
    acc = graphs.accumulated_histogram(img, L)
    assert acc.count[0] == img.size and acc.count[-1] == 1
    assert np.all(np.diff(acc.count) <= 0) and acc.percent[0] == pytest.approx(100)


def test_dark_current_slopes_and_upper_limit():
    """Section 7.1: slope of the dark mean / K and of the dark variance / K^2; a rate not
    above its SE is reported as the upper limit mu_I + sigma_I."""
    t = np.linspace(0.1, 0.6, 6)
    K = Estimate(0.5, 0.0, "DN/e-")
    out = dark_current_4(t, 10 + 0.5 * 20 * t, 4 + 0.25 * 20 * t, K)
    assert out["mu_I_mean"].value == pytest.approx(20)
    assert out["mu_I_var"].value == pytest.approx(20)
    wiggle = np.array([0.01, -0.01, 0.01, -0.01, 0.01, -0.01])  # no trend, only scatter
    noisy = dark_current_4(t, 10 + wiggle, 4 + wiggle, K)
    assert noisy["mu_I_mean"].bound == "upper" or not noisy["mu_I_mean"].available
    few = dark_current_4(t[:5], t[:5], t[:5], K)
    assert not few["mu_I_mean"].available and "6 distinct exposure" in few["mu_I_mean"].note


def test_bspline_is_exact_for_cubics_and_its_slope_too():
    """General Eqs. 44 - 49: cubic B-splines reproduce a cubic polynomial exactly, and the
    analytic slope (Eq. 48 with Eq. 49) is its derivative; the basis sums to one."""
    x = np.linspace(0, 10, 60)
    assert np.sum(beta3(np.linspace(-1, 1, 7)[:, None] - np.arange(-4, 5)), axis=1) == pytest.approx(1.0)
    y = 1 + 2 * x - 0.3 * x**2 + 0.02 * x**3
    f = bspline_fit(x, y, 6, 10.0)
    np.testing.assert_allclose(f(x), y, atol=1e-9)
    np.testing.assert_allclose(f.slope(x), 2 - 0.6 * x + 0.06 * x**2, atol=1e-8)
    h = 1e-6
    np.testing.assert_allclose(beta3_prime(np.array([-1.5, -0.5, 0.3, 1.2])),
                               (beta3(np.array([-1.5, -0.5, 0.3, 1.2]) + h) - beta3(np.array([-1.5, -0.5, 0.3, 1.2]) - h))
                               / (2 * h), atol=1e-6)


def test_a_stack_high_passed_from_its_integer_sum_equals_the_float_average():
    """``StackImage`` with the stack's exact integer sum (what ``ares emva`` keeps) gives the
    split, the 3.1 variance and the high-passed image of the float64 average within float64
    rounding; ``prepare`` computes them once (a second call reads them back)."""
    from ares.analysis.emva.sheet import StackImage

    rng = np.random.default_rng(12)
    frames = [rng.integers(200, 3000, (M, N)).astype(np.uint16) for _ in range(9)]
    st, avg, line, total = stack_moments(iter(frames))
    assert total is not None and total.dtype == np.uint32
    exact = StackImage(avg, st.s2_temporal, 9, line=line, total=total).prepare()
    plain = StackImage(avg, st.s2_temporal, 9, line=line)
    np.testing.assert_allclose(exact.highpassed("4.0"), plain.highpassed("4.0"), rtol=0, atol=1e-9)
    assert exact.highpassed_var("3.1") == pytest.approx(plain.highpassed_var("3.1"), rel=1e-12)
    for k in ("total", "col", "row", "pix", "se_total"):
        assert getattr(exact.split("4.0"), k) == pytest.approx(getattr(plain.split("4.0"), k), rel=1e-10), k
    assert exact.split("4.0") is exact.split("4.0")  # computed once
    tiny = StackImage(avg[:15, :15], st.s2_temporal, 9).prepare()  # smaller than the 4.0 filter
    assert tiny.split("none").rows == 15


@pytest.mark.parametrize("release", ["4.0", "3.1", "none"])
@pytest.mark.parametrize("kind", ["integer sum", "float"])
def test_split_in_row_blocks_equals_the_whole_image(monkeypatch, release, kind):
    """``split`` high-passes a large image a block of rows at a time: blocks of a few rows
    give the variances of the whole image within float64 rounding."""
    import ares.analysis.spatial.nonuniformity as es

    rng = np.random.default_rng(21)
    img = rng.integers(500, 3500, (M, N)) + (np.arange(N) % 7)[None, :] * 3 + (np.arange(M) % 5)[:, None] * 4
    img = img.astype(np.int32) if kind == "integer sum" else img * 0.5
    scale = 0.5 if kind == "integer sum" else 1.0
    whole = split(img, 25.0, 2, release, 0.3, 0.2, scale=scale)
    monkeypatch.setattr(es, "BLOCK_PIXELS", 3 * N)  # blocks of 3 or 4 rows
    blocks = split(img, 25.0, 2, release, 0.3, 0.2, scale=scale)
    for k in ("total", "col", "row", "pix", "mean", "se_total", "rows", "cols"):
        assert getattr(blocks, k) == pytest.approx(getattr(whole, k), rel=1e-11), k


@pytest.mark.parametrize("release", ["4.0", "3.1"])
@pytest.mark.parametrize("dtype", [np.uint32, np.int64])
def test_highpass_in_row_blocks_is_the_whole_images(monkeypatch, release, dtype):
    """``highpass`` filters an integer image a block of rows at a time: every pixel's exact
    sums are those of the whole image, so is every value (a stack's sum: uint32, or int64
    when its range times the filter's weight leaves int32 -- then per block, some blocks
    may fit int32, the same values)."""
    import ares.analysis.spatial.nonuniformity as es

    rng = np.random.default_rng(22)
    img = rng.integers(0, 4096 * 500, (M, N)).astype(dtype)
    img[: M // 2] //= 1000  # some blocks narrow enough for int32 work, some not
    monkeypatch.setattr(es, "BLOCK_PIXELS", 1 << 30)
    whole = es.highpass(img, release, 1 / 500)
    monkeypatch.setattr(es, "BLOCK_PIXELS", 3 * N)  # blocks of 3 or 4 rows
    assert np.array_equal(es.highpass(img, release, 1 / 500), whole)
    # and the float64 smoothing of the same image (rounding only)
    b = es.HIGHPASS_BORDER[release]
    ref = (img * (1 / 500))[b:-b, b:-b] - es.smooth(img * (1 / 500), release)
    assert np.allclose(whole, ref, rtol=0, atol=1e-9 * float(np.abs(ref).max()))
