"""Bench dynamics declared in the system XML and honoured (issue 36, findings 3 and 5): frames
still exposed at the old settings are discarded after a change (``<timing discard_frames>``,
``<after quantity=...>``), the settle time is waited, and read timeouts cover the exposure.

The strict model: the emulated grabber of protocols/sim_wire.xml with
``usb_pipeline_frames=1`` keeps exposing after a stop, so the next grab's first frame was
exposed before the host changed the settings -- as a streaming sensor does."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ares.rig.factory import build_bench
from ares.protocol import load_system, save_system
from ares.scan import apply as apply_mod
from ares.scan.apply import apply_settings

ROOT = Path(__file__).resolve().parents[1]
WIRE = ROOT / "protocols" / "sim_wire.xml"
OLD_TIMING = '<timing readout_s="0.001" settle_s="0"/>'


def _system(tmp_path, timing: str | None = None):
    if timing is None:
        return load_system(WIRE)
    p = tmp_path / "wire.xml"
    text = WIRE.read_text()
    assert OLD_TIMING in text
    p.write_text(text.replace(OLD_TIMING, timing))
    return load_system(p)


def _means_after_exposure_change(system) -> tuple[np.ndarray, float]:
    """Three frames at 10 ms, then three at 20 ms: the 20 ms frames' means and the SE of one
    frame's mean (temporal noise from the difference of the last two frames)."""
    bench = build_bench(system, seed=2, faults={"usb_pipeline_frames": 1})
    try:
        first = {"exposure": 0.01, "light": 2e5}
        apply_settings(bench, system, first)
        list(bench.frames.grab(3))
        apply_settings(bench, system, {"exposure": 0.02, "light": 2e5}, first)
        frames = [f.data.astype(np.float64) for f in bench.frames.grab(3)]
    finally:
        bench.close()
    se = np.std(frames[2] - frames[1]) / np.sqrt(2) / np.sqrt(frames[0].size)
    return np.array([f.mean() for f in frames]), se


def test_a_frame_exposed_at_the_old_settings_is_discarded_when_declared(tmp_path):
    means, se = _means_after_exposure_change(_system(tmp_path, '<timing readout_s="0.001" discard_frames="1"/>'))
    assert abs(means[0] - means[1:].mean()) < 6 * se * np.sqrt(1.5), (means, se)


def test_without_the_declaration_the_frame_in_flight_is_discarded_all_the_same(tmp_path):
    """The strict model is strict: with the declared waits only (``<settle by="time">``, no
    ``discard_frames``) the device still delivers the queued frame first, exposed at 10 ms (its own
    record); the host cannot tell it from a fresh one (sim_wire's header carries no time) and
    discards one frame after the register change (``ares.scan.in_flight``): the stack is at 20 ms."""
    system = _system(tmp_path, '<timing readout_s="0.001"><settle by="time"/></timing>')
    means, se = _means_after_exposure_change(system)
    assert abs(means[0] - means[1:].mean()) < 6 * se * np.sqrt(1.5), (means, se)
    bench = build_bench(system, seed=2, faults={"usb_pipeline_frames": 1})
    try:
        apply_settings(bench, system, {"exposure": 0.01, "light": 2e5})
        list(bench.frames.grab(3))
        rec = apply_settings(bench, system, {"exposure": 0.02, "light": 2e5}, {"exposure": 0.01, "light": 2e5})
        kept = [f.meta["counter"] for f in bench.frames.grab(3)]
        truth = bench.emulators["usb"].exposed_with
    finally:
        bench.close()
    assert truth[kept[0] - 1]["exposure_s"] == 0.01  # the device did send one exposed at the old settings
    assert [truth[n]["exposure_s"] for n in kept] == [0.02] * 3
    assert rec["discarded"] == 1 and rec["in_flight"]["evidence"] == "none"


def test_by_default_the_frames_prove_the_bench_settled(tmp_path):
    """Settling by evidence (the default, ares.scan.settling): no declaration, and the stale
    frame is not in the stack either."""
    means, se = _means_after_exposure_change(_system(tmp_path))
    assert abs(means[0] - means[1:].mean()) < 6 * se * np.sqrt(1.5), (means, se)


def test_settle_and_discard_per_quantity(tmp_path, monkeypatch):
    sy = _system(tmp_path, '<timing readout_s="0.001" settle_s="0.2" discard_frames="1">'
                           '<after quantity="light" settle_s="0.7" discard_frames="2"/><settle by="time"/></timing>')
    assert sy.timing.after_change("light") == (0.7, 2) and sy.timing.after_change("registers") == (0.2, 1)
    assert sy.timing.after_change("temperature") == (0.0, 0)
    waited = []
    monkeypatch.setattr(apply_mod, "wait", lambda s, cancel=None, **clock: waited.append(s))
    bench = build_bench(sy, seed=1)
    try:
        usb = bench.emulators["usb"]
        before = usb.counter
        apply_settings(bench, sy, {"exposure": 0.01, "light": 1e5})  # register and light changed
        assert waited == [0.7] and usb.counter - before == 2  # the longest settle, the most frames
        apply_settings(bench, sy, {"exposure": 0.01, "light": 1e5}, {"exposure": 0.01, "light": 1e5})
        assert waited == [0.7] and usb.counter - before == 2  # nothing changed: no wait, no discard
        apply_settings(bench, sy, {"exposure": 0.02, "light": 1e5}, {"exposure": 0.01, "light": 1e5})
        assert waited == [0.7, 0.2] and usb.counter - before == 3
    finally:
        bench.close()
    save_system(sy, tmp_path / "again.xml")
    assert load_system(tmp_path / "again.xml").timing == sy.timing


def test_read_timeout_covers_a_long_exposure(tmp_path):
    """sim_wire.xml reads with timeout_ms=2000; a 5 s exposure needs 5 s + readout + margin."""
    sy = _system(tmp_path)
    bench = build_bench(sy, seed=1)
    try:
        seen = []
        dev = bench.frames.dev
        read = dev.read
        dev.read = lambda ep, buf, timeout=None: (seen.append(timeout), read(ep, buf, timeout=timeout))[1]
        apply_settings(bench, sy, {"exposure": 5.0, "light": 0.0})
        list(bench.frames.grab(1))
        assert seen and min(seen) == round(1000 * (5.0 + 0.001 + 0.5))
        apply_settings(bench, sy, {"exposure": 0.01, "light": 0.0})
        seen.clear()
        list(bench.frames.grab(1))
        assert min(seen) == 2000  # the XML's timeout when a frame is quicker
    finally:
        bench.close()


def test_flush_drops_bytes_held_over():
    bench = build_bench(load_system(WIRE), seed=1)
    try:
        bench.frames._carry += b"stale bytes of an earlier frame"
        bench.frames.flush()
        assert not bench.frames._carry
        assert len(list(bench.frames.grab(2))) == 2 and bench.frames.stats()["resyncs"] == 0
    finally:
        bench.close()
