"""Simulator speed and the error of its fast approximations; writes benchmarks/sim.md.

Run on one core for the figures in sim.md::

    OMP_NUM_THREADS=1 taskset -c 0 .venv/bin/python benchmarks/bench_sim.py

Times are medians over repeated single-frame renders (after one warm-up render of the
same scene, so the per-call plan is cached as it is when a scan grabs frame after
frame). Ratios are against numpy's exact Poisson for one frame, measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np
from scipy import stats

from ares.sim import SensorParams, SimSensor, make_sim_bench
from ares.sim import fused, noise
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

SHIPPED: dict = {}  # shape -> (fast path, shipped numpy, shipped fused) ms per frame


def median_ms(fn, repeat):
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(ts))


def paired_ms(fa, fb, repeat):
    """(median ms of fa, of fb, median and quartiles of the per-round ratio fb / fa): the two
    timed alternately, so that both see the same machine load."""
    fa(), fb()
    ta, tb = [], []
    for _ in range(repeat):
        for fn, ts in ((fa, ta), (fb, tb)):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
    r = np.array(tb) / np.array(ta)
    return 1e3 * float(np.median(ta)), 1e3 * float(np.median(tb)), float(np.median(r)), tuple(np.percentile(r, [25, 75]))


def timing_rows(shape, repeat):
    rows, cols = shape
    size = rows * cols
    rng = np.random.default_rng(0)
    base = median_ms(lambda: rng.poisson(3000.0, size), repeat)
    normal = median_ms(lambda: rng.standard_normal(size, dtype=np.float32), repeat)
    p = SensorParams(rows=rows, cols=cols)
    s = SimSensor(p, 0)
    g = p.gain_dn_per_e()
    mid = 0.5 * p.full_well_e / (p.qe * 0.01)  # photons/pixel/s for half full well at 10 ms
    cases = [
        ("numpy exact Poisson, q=3000 (baseline)", None, base),
        ("numpy standard_normal float32", None, normal),
        ("dark frame, auto", dict(dark=True), None),
        ("flat at 50 % full well, auto (fast path)", dict(photon_flux=mid), None),
        ("flat at 95 % full well, auto (clipping path)", dict(photon_flux=1.9 * mid), None),
        ("flat at 50 % full well, lag 1 % (state path)", dict(photon_flux=mid, lag_scale=1.0), "lag"),
        ("low light q = 12 e-, auto (exact Poisson)", dict(photon_flux=2000.0), None),
        ("low light q = 12 e-, gaussian", dict(photon_flux=2000.0, shot_noise="gaussian"), None),
        ("flat at 50 % full well, exact", dict(photon_flux=mid, shot_noise="exact"), None),
    ]
    bench = make_sim_bench(p, 0)
    bench.light.set_level(mid)

    def grab16():
        for _ in bench.frames.grab(16):
            pass

    cases.append(("register bench grab(16), per frame (flat 50 %)", None, median_ms(grab16, max(3, repeat // 4)) / 16))
    # the shipped sensor's ADC (INL 0.5 LSB): binary search vs the exact lookup table (same codes)
    from ares.sim.adc import Adc

    adc = Adc(p.replace(adc_inl_lsb=0.5), np.random.default_rng(0))
    x = rng.uniform(-10, p.max_code + 10, size).astype(np.float32)
    cases.append(("ADC with INL, np.searchsorted per frame (before)", None,
                  median_ms(lambda: np.searchsorted(adc.thresholds, x, side="right"), repeat)))
    cases.append(("ADC with INL, lookup table per frame (bit-identical)", None, median_ms(lambda: adc._lookup(x), repeat)))
    fused.warm()
    cases.append(("ADC with INL, fused lookup per frame (numba, bit-identical)", None,
                  median_ms(lambda: fused.adc_lookup(x.reshape(rows, cols), adc, np.empty((rows, cols), np.uint16)),
                            repeat)))
    # the shipped protocols/sim_sensor.xml settings (lag 1e-4, INL/DNL, dark current, defects)
    # against the fast path, both per frame of an 8-frame stack at 50 % full well
    from ares.sim.from_system import sim_params
    from ares.protocol import load_system

    sp = sim_params(load_system(Path(__file__).resolve().parent.parent / "protocols" / "sim_sensor.xml"))
    sp = sp.replace(rows=rows, cols=cols)
    fast_s, ship = SimSensor(p, 0), SimSensor(sp, 0)
    fast_ms, fused_ms, ratio, quart = paired_ms(lambda: fast_s.render(8, exposure_s=0.01, photon_flux=mid),
                                                lambda: ship.render(8, exposure_s=0.01, photon_flux=mid), 2 * repeat)
    fast_ms, fused_ms = fast_ms / 8, fused_ms / 8
    cases.append(("fast path, 8-frame stack, per frame (default sensor, 50 % FW)", None, fast_ms))
    with fused.enabled(False):
        numpy_ms = median_ms(lambda: ship.render(8, exposure_s=0.01, photon_flux=mid), repeat) / 8
    cases.append(("shipped sim_sensor.xml settings, numpy path, per frame", None, numpy_ms))
    cases.append(("shipped sim_sensor.xml settings, fused kernels, per frame", None, fused_ms))
    low = 130.0 / (sp.qe * 0.01)  # 130 e-: exact Poisson photo charge (the alias method), as 11 of make run's levels
    cases.append(("shipped settings at 130 e- (exact Poisson), fused kernels, per frame", None,
                  median_ms(lambda: ship.render(8, exposure_s=0.01, photon_flux=low), repeat) / 8))
    cases.append(("shipped settings, dark frame, fused kernels, per frame", None,
                  median_ms(lambda: ship.render(8, exposure_s=0.01, photon_flux=0.0), repeat) / 8))
    # where the shipped frame's time goes: the same sensor without its lag takes the fast path (its
    # INL ADC included); the lag forces the general path, whose random draws alone are three 16-bit
    # words a pixel (read noise, photo and dark shot noise: the lag carries the photo charge alone,
    # so they are not one draw) where the fast path draws one
    no_lag = SimSensor(sp.replace(lag_fraction=0.0), 0)
    assert no_lag.frame_path(exposure_s=0.01, photon_flux=mid)[0], "the row below is the fast path"
    own_fast = median_ms(lambda: no_lag.render(8, exposure_s=0.01, photon_flux=mid), repeat) / 8
    cases.append(("shipped settings without their lag: the fast path (INL ADC), per frame", None, own_fast))
    frng = np.random.default_rng(1)
    draws3 = median_ms(lambda: [noise.words16(frng, size) for _ in range(3)], repeat)
    cases.append(("the general path's random words (three a pixel), per frame", None, draws3))
    SHIPPED[shape] = (fast_ms, numpy_ms, fused_ms, ratio, quart, own_fast, draws3)
    out = []
    lagged = SimSensor(p.replace(lag_fraction=0.01), 0)
    for name, kw, fixed in cases:
        if kw is None:
            ms = fixed
        else:
            sensor = lagged if fixed == "lag" else s
            ms = median_ms(lambda: sensor.render(1, exposure_s=0.01, **kw), repeat)
        out.append((name, ms, ms / base))
    return out, g


def shot_error_rows(n_samples):
    p = SensorParams(rows=100, cols=100, conversion_gain_uv_per_e=250.0, qe=1.0).noiseless()
    frames = max(1, n_samples // (p.rows * p.cols))
    rows = []
    for i, q in enumerate((1.0, 3.0, 6.0, 10.0, 30.0, 100.0, 1000.0)):
        res = {}
        for j, mode in enumerate(("exact", "gaussian")):
            f = SimSensor(p, 10 * i + j).render(frames, exposure_s=1.0, photon_flux=q, black_level_dn=64, shot_noise=mode)
            e = f.astype(np.float64).ravel() - 64
            var = e.var(ddof=1) - (1 / 12 if mode == "gaussian" else 0.0)
            res[mode] = (e.mean(), var, stats.skew(e))
        d = SensorParams()
        s2 = d.read_noise_e**2 + (d.chain_noise_dn**2 + 1 / 12) / d.gain_dn_per_e() ** 2
        skew_total = float(noise.shot_skewness(q, s2))
        auto = "exact" if noise.exact_mask(q, s2, "auto") else "gaussian"
        n = frames * p.rows * p.cols
        se = (np.sqrt((q + 2 * q * q) / n), np.sqrt(6 / n))  # SE of the sample variance, skewness
        rows.append((q, res["exact"], res["gaussian"], 1 / np.sqrt(q), skew_total, auto, se))
    return rows, frames * p.rows * p.cols


def table_stats():
    rng = np.random.default_rng(0)
    z = noise.normal(rng, (4_000_000,), fast=True).astype(np.float64)
    return z.mean(), z.var(), stats.kurtosis(z, fisher=False), np.abs(z).max()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--samples", type=int, default=400_000)
    args = ap.parse_args()
    lines = ["# Simulator benchmark", "",
             f"Generated by `benchmarks/bench_sim.py` on {platform.processor() or platform.machine()}, "
             f"numpy {np.__version__}; run it on one core (`OMP_NUM_THREADS=1 taskset -c 0`). "
             "The machine is shared, so absolute times drift; ratios to the baseline measured in "
             "the same run are the stable figures. "
             f"Load average at the start: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores.", "",
             "Paths (chosen per render call, see `ares/sim/sensor.py`): the *fast path* folds every per-pixel "
             "temporal term (read, chain, dark shot, photo shot) into one Gaussian draw from a 2^16-entry "
             "inverse-CDF table; it is taken when no pixel needs exact Poisson, there is no lag and no pixel "
             "can reach the full well. Otherwise photo and dark charge are drawn separately (exact Poisson by "
             "Walker's alias method for a uniform mean, numpy's Poisson for maps), lag and full-well clipping "
             "applied. `exact` mode draws all shot noise exactly and Gaussian terms with numpy's ziggurat.", "",
             "Targets (full-model frame, one core): 640x480 <= 3 ms, 1920x1080 <= 25 ms median -- the fast-path "
             "rows below.", ""]
    for shape in ((480, 640), (1080, 1920)):
        rows, g = timing_rows(shape, args.repeat)
        lines += [f"## One frame, {shape[1]}x{shape[0]}, default SensorParams (G = {g:.2f} DN/e-, all defects on)", "",
                  "| case | median ms/frame | ratio to numpy Poisson |", "|---|---:|---:|"]
        lines += [f"| {name} | {ms:.2f} | {ratio:.3f} |" for name, ms, ratio in rows]
        fast_ms, numpy_ms, fused_ms, ratio, (lo, hi), own_fast, draws3 = SHIPPED[shape]
        lines += ["", f"Shipped settings against the fast path: {ratio:.2f}x with the fused kernels "
                      f"(numba; target <= 2x; median of {2 * args.repeat} rounds timed alternately, quartiles "
                      f"{lo:.2f}-{hi:.2f}x), {numpy_ms / fast_ms:.2f}x on the numpy path; fused / numpy "
                      f"{fused_ms / numpy_ms:.2f}. Same codes on both paths (tests/test_sim_fused.py). "
                      f"Without its lag (1e-4) the shipped sensor's frame takes the fast path, "
                      f"{own_fast / fast_ms:.2f}x the default sensor's (INL/DNL look-up included); the lag forces "
                      f"the general path (the photo charge drawn apart from the read noise and the dark charge, "
                      f"to carry its share into the next frame), {fused_ms / own_fast:.2f}x that, whose random "
                      f"words alone take {draws3 / fast_ms:.2f}x the default sensor's whole fast-path frame."]
        lines.append("")
    rows, n = shot_error_rows(args.samples)
    lines += ["## Shot noise: fast Gaussian vs exact Poisson", "",
              f"G = 1 DN/e-, no other noise, {n} samples per cell (Gaussian variance with the 1/12 DN^2 "
              "quantization removed; Poisson samples are integers and need no correction). "
              "`auto` column: what auto mode picks with the default read/chain noise "
              "(skewness of Poisson + Gaussian noise vs the tolerance "
              f"{noise.AUTO_SKEW_TOLERANCE}).", "",
              "| q e- | exact mean | exact var | exact skew | gauss mean | gauss var | gauss skew | "
              "SE var, skew | Poisson skew 1/sqrt(q) | skew with default noise | auto |",
              "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for q, ex, ga, sk, skt, auto, se in rows:
        lines.append(f"| {q:g} | {ex[0]:.4f} | {ex[1]:.4f} | {ex[2]:.3f} | {ga[0]:.4f} | {ga[1]:.4f} | "
                     f"{ga[2]:.3f} | {se[0]:.3f}, {se[1]:.3f} | {sk:.3f} | {skt:.3f} | {auto} |")
    m, v, k, zmax = table_stats()
    lines += ["", "## Fast N(0,1) table (2^16 inverse-CDF entries)", "",
              f"4e6 draws: mean {m:.5f}, variance {v:.5f}, kurtosis {k:.4f} (normal: 3), max |z| {zmax:.3f}.", ""]
    publish("sim", lines)


if __name__ == "__main__":
    main()
