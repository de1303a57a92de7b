"""The numba high-pass kernel (``highpass_kernel``) against the numpy path of
``emva_spatial`` (the reference: exact integer box sums), on random integer images of odd
sizes down to the smallest the filters allow, and int64 stack sums near the type's range."""

import math

import numpy as np
import pytest

pytest.importorskip("numba")

from ares.analysis.kernels import jit  # noqa: E402
from ares.analysis.spatial import nonuniformity as es  # noqa: E402

@pytest.fixture(autouse=True)
def any_size(monkeypatch):
    """The kernel on these small images (in use it takes images of >= KERNEL_MIN_PIXELS)."""
    monkeypatch.setattr(es, "KERNEL_MIN_PIXELS", 0)


FIELDS = ("total", "col", "row", "pix", "se_total", "se_col", "se_row", "se_pix", "mean")


def _cases():
    rng = np.random.default_rng(40)
    # (release, image): 12-bit pair sums (int32 work), uint32, and int64 stack sums that need
    # int64 work, centred near +-2**62 (the centring keeps them exact)
    yield "4.0", rng.integers(0, 8191, (21, 21)).astype(np.int32)  # the smallest the 4.0 filter allows
    yield "4.0", rng.integers(0, 8191, (23, 37)).astype(np.uint32)
    yield "4.0", (rng.integers(0, 8191, (61, 45)) + np.add.outer(np.arange(61) ** 2, 3 * np.arange(45))).astype(np.int32)
    yield "4.0", (2**62 + rng.integers(-5 * 10**10, 5 * 10**10, (21, 23))).astype(np.int64)
    yield "4.0", (-(2**62) + rng.integers(0, 409_500, (41, 29))).astype(np.int64)
    yield "3.1", rng.integers(0, 65536, (7, 7)).astype(np.int64)  # the smallest the 3.1 filter allows
    yield "3.1", rng.integers(0, 8191, (33, 19)).astype(np.int32)


@pytest.mark.parametrize("release,x", list(_cases()))
def test_kernel_equals_numpy_path(release, x):
    assert es._kernel_sums(x, release) is not None  # the kernel does run on this image
    ref_hp = (lambda: es.highpass(x, release, 0.01))
    with jit.avoided():
        want_hp = ref_hp()
        want = es.split(x, 3.0, 100, release, 0.05, 0.04, scale=0.01)
    got_hp = ref_hp()
    got = es.split(x, 3.0, 100, release, 0.05, 0.04, scale=0.01)
    # the filtered image: the same exact integers times the same scale
    np.testing.assert_array_equal(got_hp, want_hp)
    # the variances: the same integer sums, the float64 squares added in another order
    scale = want.total + want.se_total
    for s, w in ((got, want), (got.extended, want.extended)):
        for f in FIELDS:
            assert math.isclose(getattr(s, f), getattr(w, f), rel_tol=1e-12, abs_tol=1e-12 * abs(scale)), f


def test_integer_sums_beyond_int64_take_the_numpy_path():
    """Sums of z that might not fit int64: the kernel is not used; the numpy path's split is
    the float64 image's (float64 rounding apart)."""
    x = np.zeros((21, 23), np.int64)
    x[::2, ::3] = 3 * 10**11
    assert es._kernel_sums(x, "4.0") is None
    got, want = es.split(x, 0.0, 1, "4.0"), es.split(x.astype(np.float64), 0.0, 1, "4.0")
    assert want.total > 1e20
    for f in FIELDS:
        assert math.isclose(getattr(got, f), getattr(want, f), rel_tol=1e-9, abs_tol=1e-9 * want.total), f


def test_avoided_and_uint64_take_the_numpy_path():
    x = np.random.default_rng(3).integers(0, 4096, (25, 27))
    with jit.avoided():
        assert es._kernel_sums(x.astype(np.int32), "4.0") is None
    assert es._kernel_sums(x.astype(np.uint64), "4.0") is None
    assert es._kernel_sums(x.astype(np.uint16), "4.0") is not None


def test_ares_emva_loads_the_kernels_only_for_a_large_set():
    from types import SimpleNamespace

    from ares.commands import emva

    lv = SimpleNamespace(images=(None,) * 300)
    small = SimpleNamespace(levels=(lv,), width=640, height=480)  # the reference CCD set: 92 Mpx
    large = SimpleNamespace(levels=(lv,), width=2048, height=1536)  # 944 Mpx
    assert not emva.uses_kernels(small)
    assert emva.uses_kernels(large)


def test_small_images_take_the_numpy_path(monkeypatch):
    monkeypatch.setattr(es, "KERNEL_MIN_PIXELS", 1_000_000)
    x = np.random.default_rng(5).integers(0, 4096, (480, 640)).astype(np.int32)
    assert es._kernel_sums(x, "4.0") is None
    assert es._kernel_sums(np.zeros((1000, 1000), np.int32), "4.0") is not None
