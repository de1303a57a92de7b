"""Time remaining (ares.scan.eta) from measured frame and stage times, fed made-up event
times (no clock): exact for a steady scan once one stage has ended, and it does not
carry the first stage's one-off work or its slower frames into every later estimate."""

from __future__ import annotations

import pytest

from ares.scan.eta import Eta


def simulate(eta: Eta, stages: list[tuple[int, float, float]], upto: int):
    """Feed ``upto`` stages of (frames, s/frame, s of stage work); return (ETA, the true time
    left, the old frames-left / overall-rate estimate) after the first frame of stage ``upto``."""
    t = 0.0
    out = None
    done = 0
    n_total = sum(n for n, _, _ in stages)
    total = sum(n * f + w for n, f, w in stages)
    for i, (n, per_frame, work) in enumerate(stages):
        eta.stage_started(t)
        t += work / 2  # settling before the first frame
        for _ in range(n):
            t += per_frame
            eta.frame(t)
            done += 1
            if i == upto and out is None:
                out = (eta.remaining(t), total - t - (work / 2), (n_total - done) * t / done)
        t += work / 2  # the stage's analysis and write
        eta.stage_finished(t)
    return out


def test_steady_scan_is_exact_after_the_first_stage():
    stages = [(16, 0.01, 0.5)] * 10
    got, true, _ = simulate(Eta(160, 10), stages, upto=1)
    assert got == pytest.approx(true, rel=0.07)  # one frame interval of the new stack is unknown


def test_first_stage_one_off_work_and_slow_frames_do_not_dominate():
    stages = [(32, 0.03, 3.0)] + [(16, 0.01, 0.5)] * 20
    got, true, naive = simulate(Eta(32 + 320, 21), stages, upto=3)
    assert got == pytest.approx(true, rel=0.10)
    assert abs(naive / true - 1) > 0.3  # the old estimate (frames left / overall rate) is far off


def test_nothing_measured_gives_the_prior():
    assert Eta(10, 2, prior_s=3.0).remaining(0.0) == 3.0
    assert Eta(10, 2).remaining(0.0) is None
