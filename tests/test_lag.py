"""Image lag from a bright->dark sequence with a known carried-over fraction."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.ptc.lag import image_lag, lag_from_sequence


def sequence(rng, lag=0.02, cycles=5, n_bright=4, n_dark=4, q=8000.0, K=0.3, shape=(64, 64)):
    frames, lit, carry = [], [], np.zeros(shape)
    for _ in range(cycles):
        for on in [True] * n_bright + [False] * n_dark:
            charge = rng.poisson(q, shape) if on else np.zeros(shape)
            out = (1 - lag) * charge + carry
            carry = lag * charge
            frames.append(np.round(K * (out + rng.normal(0, 3, shape)) + 100))
            lit.append(on)
    return np.array(frames), np.array(lit)


def test_lag_fraction_recovered():
    f, lit = sequence(np.random.default_rng(0))
    r = lag_from_sequence(f, lit)
    assert r.cycles == 5
    assert r.lag_pct.value == pytest.approx(2.0, abs=0.1)
    assert abs(r.lag_pct.value - 2.0) < 5 * r.lag_pct.se


def test_no_lag_and_missing_parts():
    f, lit = sequence(np.random.default_rng(1), lag=0.0, cycles=1)
    r = lag_from_sequence(f, lit)
    assert abs(r.lag_pct.value) < 0.1 and "pixel scatter" in r.lag_pct.note
    assert not lag_from_sequence(f[:4], lit[:4]).lag_pct.available
    assert not image_lag(f[4:], f[5], f[6:]).lag_pct.available


def test_a_two_axis_sweep_with_darks_after_gives_a_lag_map_on_truth(tmp_path):
    """dark="after" grabs each point's matched dark right after its flat: the lag analysis
    reads every point as a bright->dark cycle. On the simulator (lag 2 % at the default
    tx_low, scaled by 2**(-(V - V0)/0.25)) each point's lag is the truth within 4 SE."""
    import os

    from ares.protocol import load_scan
    from ares.scan import Runner

    here = os.path.join(os.path.dirname(__file__), "..", "fixtures", "xml", "small")
    system = open(os.path.join(here, "sim_small.xml")).read().replace(
        '<param name="hot_rate_ppm" type="float" value="0"/>',
        '<param name="hot_rate_ppm" type="float" value="0"/>\n    <param name="lag_fraction" type="float" value="0.02"/>')
    (tmp_path / "sys.xml").write_text(system)
    (tmp_path / "scan.xml").write_text(
        '<scan name="lagmap" version="1"><system href="sys.xml"/><settings><set quantity="exposure" value="0.01"/>'
        '<set quantity="light" value="300000"/></settings><frames>8</frames><stages>'
        '<sweep name="bias" scene="flat" dark="after"><axis field="sf_bias"><values>1.2 2.0</values></axis>'
        '<axis field="tx_low"><values>-0.8 -0.5 -0.2</values></axis></sweep></stages>'
        '<analyses><analysis name="lag"/></analyses></scan>')
    out = Runner(load_scan(tmp_path / "scan.xml"), seed=3).run()
    cycles = out.scan_results["lag"]["cycles"]
    assert len(cycles) == 6
    v0 = -128 / 255
    for c in cycles.values():
        lag = c["lag_pct"]
        truth = 100 * 0.02 * 2 ** (-(c["settings"]["reg:tx_low"] - v0) / 0.25)
        assert abs(lag["value"] - truth) < 4 * lag["se"] + 0.02 * truth, (c, truth)
    values = sorted((c["settings"]["reg:tx_low"], c["lag_pct"]["value"]) for c in cycles.values())
    assert values[0][1] > 2 * values[-1][1]  # the map shows the bias dependence


def test_frame_mean_lag_se_covers_the_truth(frames=4):
    """issue 48 (benchmarks/truth_z.md): a cycle's lag from its stacks' frame means takes its
    SE from the scatter of the m settled dark frame means -- on m - 1 dof, so with Student's t,
    and x sqrt(1 + 1/m) for the first dark frame less their mean. The bare scatter of 2
    settled frames (4-frame stacks, 1 dof) gave the shipped lag scan lags up to 93 SE from
    the simulator's truth, "ok" (here: 24 % of the cycles beyond 3 SE). 600 cycles: frame-mean
    noise 0.05 DN, bright 1000 DN, lag 1 %; (lag - truth) / (SE / t) is exactly Student's t."""
    from ares.results.analyses import lag_cycle

    rng = np.random.default_rng(5)
    z = []
    for _ in range(600):
        fb = list(1100 + 0.05 * rng.standard_normal(frames))
        fd = 100 + 0.05 * rng.standard_normal(frames)
        fd[0] += 10.0  # 1 % of the 1000 DN bright signal
        est, _ = lag_cycle(fb, list(fd))
        z.append((est.value - 1.0) / est.se)
    z = np.abs(np.array(z))
    assert np.mean(z > 3) <= 0.005, np.mean(z > 3)  # 3 SE cover what they claim (0.27 % outside)
