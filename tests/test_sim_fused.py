"""The fused simulator kernels (numba) give exactly the codes of the numpy path: the
general charge path (photo and dark charge apart, lag carried frame to frame, full-well
clip) and the INL/DNL ADC lookup, on the shipped sensor and on variants."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("numba")

from ares.sim import SimSensor, fused  # noqa: E402
from ares.sim.params import SensorParams  # noqa: E402


def shipped() -> SensorParams:
    from ares.sim.from_system import sim_params
    from ares.protocol import load_system

    return sim_params(load_system("protocols/sim_sensor.xml"))


def frames(params: SensorParams, seed: int, on: bool) -> list[np.ndarray]:
    with fused.enabled(on):
        s = SimSensor(params, seed=seed)
        out = [s.render(5, exposure_s=0.01, photon_flux=2e5),
               s.render(3, exposure_s=0.01, photon_flux=0.0),  # the lag carried into darks
               s.render(5, exposure_s=0.03, photon_flux=3e6),  # past full well: the clip
               s.render(4, exposure_s=0.01, photon_flux=1e6, temperature_c=45.0),
               s.render(3, exposure_s=0.01, photon_flux=300.0),  # low light: exact Poisson by alias
               s.render(2, exposure_s=2.0, photon_flux=0.0)]  # a long dark
    return out


VARIANTS = {"shipped": {}, "no_lag": {"lag_fraction": 0.0},
            "no_dark": {"dark_current_e_per_s": 0.0, "dsnu_e_per_s": 0.0, "dark_tail_e_per_s": 0.0},
            "ideal_adc": {"adc_inl_lsb": 0.0, "adc_dnl_lsb": 0.0}, "lag_1pct": {"lag_fraction": 0.01},
            "flutter": {"flutter_pct": 1.0},  # flutter: the numpy path, still the same codes
            # the line terms the lookup adds in its pass: frame-global alone, none at all
            "frame_global_only": {"row_temporal_dn": 0.0}, "no_line_terms": {"row_temporal_dn": 0.0,
                                                                              "col_temporal_dn": 0.0, "frame_global_dn": 0.0},
            "no_rts": {"rts_rate_ppm": 0.0}, "many_rts": {"rts_rate_ppm": 2e4}, "adc_gains": {"adc_gain": (1.0, 1.03)}}  # gains: the numpy lookup


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_fused_frames_equal_the_numpy_path(variant):
    p = dataclasses.replace(shipped(), rows=96, cols=128, **VARIANTS[variant])
    a, b = frames(p, 11, True), frames(p, 11, False)
    for x, y in zip(a, b):
        assert x.dtype == y.dtype and np.array_equal(x, y)
    fused.warm()  # warm() loads the very signatures a frame uses: nothing compiles mid-scan
    assert len(fused._compiled.signatures) == 1 and len(fused._compiled_lookup.signatures) == 1
    assert len(fused._compiled_alias.signatures) == 1


@pytest.mark.parametrize("bits, inl, dnl, seed", [(12, 0.5, 0.2, 0), (12, 1.5, 0.1, 1), (10, 3.0, 0.6, 2),
                                                  (8, 0.0, 0.9, 3), (14, 2.0, 0.3, 4), (16, 1.0, 0.5, 5)])
def test_fused_adc_lookup_equals_searchsorted(bits, inl, dnl, seed):
    """The sub-cell kernel gives searchsorted's codes for every input: values at, and one
    float32 step either side of, each transition level and each sub-cell edge, far
    outside the range and infinite, and random ones (8 to 16 bits: 64 down to 8 sub-cells per LSB)."""
    from ares.sim.adc import Adc

    adc = Adc(SensorParams(rows=8, cols=8, adc_bits=bits, adc_inl_lsb=inl, adc_dnl_lsb=dnl),
              np.random.default_rng(seed))
    sub, S = adc.sub_cells()
    assert sub.size <= 1 << 20 and S == {8: 64, 10: 64, 12: 64, 14: 32, 16: 8}[bits]
    t32 = adc.thresholds.astype(np.float32)
    edges = (-1.0 + np.arange(sub.size + 1) / S).astype(np.float32)[:: max(1, sub.size // 50_000)]
    x = np.concatenate([
        np.random.default_rng(seed).uniform(-20, adc.max_code + 20, 100_000).astype(np.float32),
        t32, np.nextafter(t32, np.float32(-np.inf)), np.nextafter(t32, np.float32(np.inf)),
        edges, np.nextafter(edges, np.float32(-np.inf)), np.nextafter(edges, np.float32(np.inf)),
        np.array([-np.inf, -1e30, 1e30, np.inf, -1, -0.5, 0, 0.5, adc.max_code + 2, adc.max_code + 1.5], np.float32)])
    x = np.concatenate([x, np.zeros(-x.size % 64, np.float32)]).reshape(-1, 64)
    want = np.searchsorted(adc.thresholds, x.astype(np.float64), side="right").astype(np.uint16)
    out = np.empty(x.shape, np.uint16)
    assert fused.adc_lookup(x.copy(), adc, out)
    assert np.array_equal(out, want)


def test_exact_mask_shortcut_matches_the_per_pixel_rule():
    """The auto shot-noise rule decided from the map's range gives what the per-pixel
    skewness test gives, on maps below, above and straddling the tolerance."""
    from ares.sim import noise

    rng = np.random.default_rng(2)
    v = 4.0
    for lo, hi in ((0.0, 0.5), (0.0, 3.0), (5.0, 40.0), (50.0, 5000.0), (1e-3, 1e5), (7.5, 8.5)):
        m = rng.uniform(lo, hi, (40, 50)).astype(np.float32)
        per_pixel = noise.shot_skewness(m, v) > noise.AUTO_SKEW_TOLERANCE
        got = noise.exact_mask(m, v, "auto")
        if per_pixel.all() or not per_pixel.any():
            assert got is bool(per_pixel.all()), (lo, hi)
        else:
            assert np.array_equal(got, per_pixel), (lo, hi)


@pytest.mark.parametrize("bitgen", [np.random.SFC64, np.random.PCG64, np.random.MT19937, np.random.Philox])
def test_16_bit_words_from_wider_draws_are_numpys_words(bitgen):
    """``fused.words16`` (64- or 32-bit draws viewed as uint16) gives exactly the values of
    ``integers(0, 2**16, dtype=uint16)`` and leaves the generator where it leaves it:
    whatever is pending from earlier draws, for even and odd sizes and 2-D shapes."""
    from ares.sim.fused import words16

    for pending in (0, 1, 3):
        for shape in ((480, 640), (6,), (10,), (7,), (2, 3), (1,)):
            a, b = np.random.Generator(bitgen(11)), np.random.Generator(bitgen(11))
            if pending:
                a.integers(0, 1 << 16, size=pending, dtype=np.uint16)
                b.integers(0, 1 << 16, size=pending, dtype=np.uint16)
                a.integers(0, 1 << 32, size=1, dtype=np.uint32)  # a 32-bit half may now be pending
                b.integers(0, 1 << 32, size=1, dtype=np.uint32)
            want = a.integers(0, 1 << 16, size=shape, dtype=np.uint16)
            got = words16(b, shape)
            assert got.dtype == np.uint16 and got.shape == want.shape
            np.testing.assert_array_equal(got, want)
            assert a.integers(0, 1 << 16, size=5, dtype=np.uint16).tolist() == words16(b, (5,)).tolist()
            assert a.random() == b.random()


@pytest.mark.parametrize("seed, n", [(0, 1), (1, 7), (2, 76_800), (3, 0)])
def test_sfc64_kernel_is_numpys_sfc64(seed, n):
    """The numba SFC64 gives random_raw's outputs and leaves the generator where
    random_raw leaves it (the next draws of every kind agree); other generators: None."""
    a = np.random.Generator(np.random.SFC64(seed))
    b = np.random.Generator(np.random.SFC64(seed))
    a.random(3)  # mid-stream
    b.random(3)
    assert np.array_equal(fused.sfc64_raw(a.bit_generator, n), b.bit_generator.random_raw(n))
    assert a.bit_generator.state["state"]["state"].tolist() == b.bit_generator.state["state"]["state"].tolist()
    assert np.array_equal(a.standard_normal(5), b.standard_normal(5)) and a.integers(0, 9) == b.integers(0, 9)
    assert fused.sfc64_raw(np.random.PCG64(seed), n) is None


@pytest.mark.parametrize("seed, k, n, pending", [
    (0, 57, 76_800, False), (1, 517, 1001, True), (2, 1, 10, False),
    (3, 3 << 29, 20_000, True),  # a quarter of the 32-bit draws rejected: Lemire's rejection taken
    (4, (1 << 31) - 1, 999, False), (5, 432, 0, True)])
def test_alias_draws_are_numpys_integers_then_random(seed, k, n, pending):
    """The alias method's draws in numba: numpy's bounded int32 integers then doubles,
    from a generator mid-stream (with a 32-bit half pending or not), the generator left
    where numpy leaves it (the next draws of every kind agree)."""
    a = np.random.Generator(np.random.SFC64(seed))
    b = np.random.Generator(np.random.SFC64(seed))
    for g in (a, b):
        g.random(3)
        if pending:  # one 32-bit draw leaves the high half of a 64-bit one for the next
            g.integers(0, 10, size=1, dtype=np.int32)
    idx, u = fused.alias_draws(a, k, n)
    assert idx.dtype == np.int32 and np.array_equal(idx, b.integers(0, k, size=n, dtype=np.int32))
    assert np.array_equal(u, b.random(size=n))
    sa, sb = a.bit_generator.state, b.bit_generator.state
    assert sa["state"]["state"].tolist() == sb["state"]["state"].tolist()
    assert (sa["has_uint32"], sa["uinteger"]) == (sb["has_uint32"], sb["uinteger"])
    assert a.integers(0, 1000, size=3, dtype=np.int32).tolist() == b.integers(0, 1000, size=3, dtype=np.int32).tolist()
    assert a.random() == b.random()
    pcg = np.random.Generator(np.random.PCG64(seed))  # other generators: numpy's own calls
    idx, u = fused.alias_draws(pcg, k, 5)
    assert np.array_equal(idx, np.random.Generator(np.random.PCG64(seed)).integers(0, k, size=5, dtype=np.int32))
