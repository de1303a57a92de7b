"""The register-driven simulated bench and its fault injection."""

import numpy as np
import pytest

from ares.errors import DeviceGone, FrameError, InputError, ValueOutOfRange
from ares.hardware.interfaces import Bench, Chamber, FrameSource, LightSource, RegisterBus
from ares.sim import (SensorParams, SimChamber, SimFrameSource, SimLightSource, SimRegisterBus,
                      make_sim_bench)
from ares.sim.regmap import CHIP_ID, SIM_REGISTER_MAP

P = SensorParams(rows=48, cols=64)


def grab(bench, n):
    return np.stack([f.data for f in bench.frames.grab(n)]).astype(np.float64)


def test_bench_implements_the_interfaces():
    b = make_sim_bench(P, seed=1)
    assert isinstance(b, Bench)
    assert isinstance(b.registers.bus, RegisterBus) and isinstance(b.registers.bus, SimRegisterBus)
    assert isinstance(b.frames, FrameSource) and isinstance(b.frames, SimFrameSource)
    assert isinstance(b.light, LightSource) and isinstance(b.light, SimLightSource)
    assert isinstance(b.chamber, Chamber) and isinstance(b.chamber, SimChamber)
    assert b.frames.shape == (48, 64) and b.frames.bit_depth == 12
    assert b.info["sensor"].params == P
    b.close()


def test_register_defaults_and_read_only_chip_id():
    b = make_sim_bench(P)
    r = b.registers
    assert r.get_raw("chip_id") == CHIP_ID
    assert r.get("exposure") == pytest.approx(0.01)
    assert r.get("analog_gain") == 1.0 and r.get("black_level") == 64
    snap = r.snapshot()
    assert set(snap) == set(SIM_REGISTER_MAP.names())
    with pytest.raises(InputError, match="read-only"):
        r.set("chip_id", 1)
    with pytest.raises(InputError, match="read-only"):
        b.registers.bus.write(0x0000, 1)
    with pytest.raises(ValueOutOfRange):
        b.registers.bus.write(0x0010, 1 << 16)


def test_exposure_register_changes_the_signal():
    b = make_sim_bench(P, seed=2)
    b.light.set_level(1e5)
    b.registers.set("exposure", 0.01)
    s1 = grab(b, 2).mean() - 64
    b.registers.set("exposure", 0.04)
    s4 = grab(b, 2).mean() - 64
    assert s4 / s1 == pytest.approx(4.0, rel=0.02)
    frames = list(b.frames.grab(2))
    assert frames[0].meta["exposure_s"] == pytest.approx(0.04)
    assert frames[1].index == frames[0].index + 1 and frames[1].timestamp > frames[0].timestamp


def test_gain_black_level_test_modes_and_streaming():
    b = make_sim_bench(P, seed=2)
    b.light.set_level(1e5)
    b.registers.set("black_level", 200)
    base = grab(b, 2).mean()
    b.registers.set("analog_gain", 2.0)
    assert (grab(b, 2).mean() - 200) / (base - 200) == pytest.approx(2.0, rel=0.02)
    b.registers.set("test_mode", 1)  # dark: no photo-charge
    assert grab(b, 2).mean() == pytest.approx(200, abs=2)
    b.registers.set("test_mode", 2)  # ADC ramp
    ramp = grab(b, 1)[0].ravel()
    assert ramp[0] == 0 and ramp[-1] == 4095 and np.all(np.diff(ramp) >= 0)
    b.registers.set("streaming", 0)
    with pytest.raises(FrameError, match="not streaming"):
        grab(b, 1)


def test_out_of_range_register_write_raises():
    b = make_sim_bench(P)
    with pytest.raises(ValueOutOfRange, match="exposure"):
        b.registers.set("exposure", 1000.0)
    with pytest.raises(ValueOutOfRange):
        b.registers.set("analog_gain", 0.5)
    with pytest.raises(ValueOutOfRange):
        b.light.set_level(-1)
    with pytest.raises(ValueOutOfRange):
        b.chamber.set_temperature(500)


def test_chamber_temperature_raises_dark_signal():
    p = P.replace(dark_current_e_per_s=500.0)
    b = make_sim_bench(p, seed=3)
    b.registers.set("exposure", 1.0)
    b.registers.set("test_mode", 1)
    b.chamber.set_temperature(52.0)
    b.chamber.settle()
    lo = grab(b, 2).mean() - 64
    b.chamber.set_temperature(60.0)
    hi = grab(b, 2).mean() - 64
    assert hi / lo == pytest.approx(2.0, rel=0.05)


def test_bias_registers_shape_noise_and_dark_current():
    b = make_sim_bench(P.replace(read_noise_e=4.0, dark_current_e_per_s=500.0), seed=4)
    b.registers.set("test_mode", 1)
    b.registers.set("exposure", 0.001)
    noise = {}
    for v in (0.0, 1.65, 3.3):
        b.registers.set("sf_bias", v)
        noise[v] = grab(b, 8).std(axis=0, ddof=1).mean()
    assert noise[0.0] > 2 * noise[1.65] and noise[3.3] > 2 * noise[1.65]
    b.registers.set("sf_bias", 1.65)
    b.registers.set("exposure", 1.0)
    b.chamber.set_temperature(60.0)
    dark = {}
    for v in (-1.0, -0.5, 0.0):
        b.registers.set("tx_low", v)
        dark[v] = grab(b, 2).mean() - 64
    assert dark[-1.0] < dark[-0.5] < dark[0.0]


def test_disconnect_fault():
    b = make_sim_bench(P, faults={"disconnect_after_frames": 5})
    got = []
    with pytest.raises(DeviceGone, match="disconnected after 5 frames"):
        for f in b.frames.grab(10):
            got.append(f.index)
    assert got == [0, 1, 2, 3, 4]
    with pytest.raises(DeviceGone):
        list(b.frames.grab(1))


def test_short_frame_fault():
    b = make_sim_bench(P, faults={"short_frame_at": 3})
    got = []
    with pytest.raises(FrameError, match="frame 3 arrived short"):
        for f in b.frames.grab(10):
            got.append(f.index)
    assert got == [0, 1, 2]
    assert len(list(b.frames.grab(2))) == 2  # the device goes on afterwards


def test_unknown_fault_is_rejected():
    with pytest.raises(InputError, match="unknown fault"):
        make_sim_bench(P, faults={"explode": 1})


def test_grab_across_render_chunks_keeps_order_and_count():
    b = make_sim_bench(P, seed=5)
    frames = list(b.frames.grab(37))
    assert [f.index for f in frames] == list(range(37))
    assert all(f.data.shape == (48, 64) and f.data.dtype == np.uint16 for f in frames)
    assert len({f.data.tobytes() for f in frames}) == 37  # temporal noise: all frames differ


def test_every_writable_field_round_trips_through_the_bus():
    b = make_sim_bench(P)
    r = b.registers
    for f in SIM_REGISTER_MAP.fields:
        if f.access == "ro":
            continue
        for raw in {0, (1 << f.width) - 1, f.default}:
            phys = f.to_physical(raw)
            if (f.minimum is not None and phys < f.minimum) or (f.maximum is not None and phys > f.maximum):
                continue
            r.set(f.name, phys)
            assert r.get_raw(f.name) == raw, f.name


def test_undefined_test_mode_written_raw_is_refused():
    b = make_sim_bench(P)
    b.registers.bus.write(SIM_REGISTER_MAP.field("test_mode").address, 3)
    with pytest.raises(InputError, match="test_mode 3 is not defined"):
        grab(b, 1)


def test_released_or_closed_grabber_gives_the_same_frames_and_truth():
    """``release()`` (the runner, between large stages) drops the operating point's maps and
    ``close()`` the fixed patterns too: both are drawn again from the seed, the same."""
    def frames(release_at=None):
        b = make_sim_bench(P, seed=4)
        b.light.set_level(2e5)
        out = []
        for i in range(3):
            if i == release_at:
                b.frames.release()
                assert b.info["sensor"]._cache is None
            out.append(grab(b, 2))
        return b, np.stack(out)

    b0, ref = frames()
    for k in (1, 2):
        np.testing.assert_array_equal(frames(release_at=k)[1], ref)
    sensor = b0.info["sensor"]
    before = sensor.truth(exposure_s=0.01, photon_flux=2e5)
    b0.close()
    assert sensor._patterns is None
    after = sensor.truth(exposure_s=0.01, photon_flux=2e5)
    def same(a, b):
        if isinstance(a, dict):
            assert a.keys() == b.keys()
            for k in a:
                same(a[k], b[k])
        elif isinstance(a, (list, tuple)) and a and isinstance(a[0], (dict, list, tuple, np.ndarray)):
            assert len(a) == len(b)
            for x, y in zip(a, b):
                same(x, y)
        else:
            np.testing.assert_array_equal(a, b)

    same(before, after)


@pytest.mark.parametrize("fields", [
    {"light": 1e4},  # exact Poisson by the alias method
    {"light": 5e5, "exposure": 0.04},  # a Gaussian draw, reaching the full well
    {"light": 2e3, "test_mode": 1},  # dark
    {"light": 0.0, "temperature": 60.0, "exposure": 1.0},  # hot dark: exact per pixel (the numpy path)
    {"light": 1e5, "test_mode": 2},  # the ADC ramp
    {"light": 1e5, "sf_bias": 2.2, "tx_low": 0.0, "analog_gain": 4.0},
])
def test_frame_cost_at_given_settings_is_the_cost_once_they_are_set(fields):
    """``frame_cost`` (what the time remaining weighs a stage by) at settings not applied
    equals the cost read after applying them, takes the path ``render`` takes, and draws
    nothing: the frames after it are the same as without it."""
    from ares.sim import cost, fused

    b, ref = make_sim_bench(P, seed=4), make_sim_bench(P, seed=4)
    got = b.frames.frame_cost(fields)
    for bench in (b, ref):
        for name, value in fields.items():
            if name == "light":
                bench.light.set_level(value)
            elif name == "temperature":
                bench.chamber.set_temperature(value)
            else:
                bench.registers.set(name, value)
    assert got == b.frames.frame_cost({})
    assert np.array_equal(grab(b, 3), grab(ref, 3))
    s = b.frames.settings()
    if s.pop("test_mode") != 2:
        s.pop("streaming")
        sens = b.frames.sensor
        kw = dict(dark=fields.get("test_mode") == 1, **s)
        fast, modes, numpy_path, exact = sens.frame_path(**kw)
        sens.render(1, **kw)
        sc, plan = sens._cache  # the path render took
        assert fast == plan["fast"]
        if not fast:
            assert modes == fused._modes(sc, plan) and numpy_path == (not fused.applies(sc, plan, 1.0))
            assert (exact > 0) == (None in modes)
    else:
        assert got == cost.ramp_cost(b.frames.sensor.patterns.adc.thresholds is not None)
    b.close()
    ref.close()


@pytest.mark.parametrize("params, kw", [
    (dict(read_noise_e=0.0, chain_noise_dn=0.0), dict(photon_flux=1e5)),  # no per-pixel temporal noise
    (dict(flutter_pct=1.0), dict(photon_flux=1e5)),  # flutter scales a lit frame's charge
    (dict(flutter_pct=1.0), dict(photon_flux=0.0)),  # ... and does nothing to a dark one
    (dict(), dict(photon_flux=1e5, shot_noise="exact")),
    (dict(), dict(photon_flux=3e3)),  # the alias method
])
def test_frame_path_names_the_kernel_choice_render_makes(params, kw):
    """``frame_path`` (costing, no plan built) and ``render`` decide the fused kernel by
    the one predicate ``fused.covers``: the same answer on the cases that bypass it."""
    from ares.sim import fused
    from ares.sim.sensor import SimSensor

    sens = SimSensor(SensorParams(rows=16, cols=24, lag_fraction=1e-3, **params), seed=2)  # lag: not the fast path
    kw = dict(exposure_s=0.01, **kw)
    fast, modes, numpy_path, _ = sens.frame_path(**kw)
    sens.render(1, **kw)
    sc, plan = sens._cache
    assert not fast and not plan["fast"]
    assert numpy_path == (not fused.applies(sc, plan, 1.0 + params.get("flutter_pct", 0.0) / 100))
    if params.get("read_noise_e") == 0.0 or kw.get("shot_noise") == "exact" or kw["photon_flux"] and "flutter_pct" in params:
        assert numpy_path


def test_frame_cost_orders_the_paths_as_they_cost():
    """Exact Poisson at low light costs more a frame than a Gaussian draw, a dark frame
    less, and the one-draw fast path least (``benchmarks/sim.md`` measures the times)."""
    b = make_sim_bench(SensorParams(rows=48, cols=64, lag_fraction=1e-4), seed=1)
    alias, gauss, dark = (b.frames.frame_cost(f) for f in ({"light": 1e4}, {"light": 5e5}, {"light": 0.0}))
    fast = make_sim_bench(P, seed=1).frames.frame_cost({"light": 5e5})
    assert alias > 1.5 * gauss and gauss > dark > fast > 0
    # a long dark frame: only its few hot pixels drawn exactly, but on the numpy path (measured
    # 1.4x the short dark frame); at 60 C every pixel exactly (numpy's Poisson, 6x and more)
    sparse, hot = (b.frames.frame_cost(f) for f in ({"light": 0.0, "exposure": 0.2},
                                                    {"light": 0.0, "exposure": 1.0, "temperature": 60.0}))
    assert dark < sparse < 2 * dark and hot > 5 * dark


@pytest.mark.parametrize("readout", [-0.001, float("nan"), float("inf")])
def test_a_paced_simulator_refuses_an_impossible_readout_time(readout):
    with pytest.raises(InputError, match="readout time"):
        make_sim_bench(P, seed=1, readout_s=readout)


def test_only_a_paced_simulator_says_its_frames_follow_the_exposure():
    assert make_sim_bench(P, seed=1, readout_s=0.0).frames.exposure_paced
    assert not make_sim_bench(P, seed=1).frames.exposure_paced
