"""A stage's register settings as one change (issue 49's first item left undone): the runner writes
them all inside one group hold where the register map declares one, so they latch together at
the next frame start; without a declared hold it writes them one at a time, as before, and the
stage's record says its change was not atomic.

The device is the wire-emulated simulator with ``usb_frame_in_flight``: a streaming sensor whose
next frame starts -- latching its held registers -- as soon as one is read out, so the first frame
after a change was latched before the hold closed (real sensors do this). The grabber's
``exposed_with`` is the device's truth: the settings each device frame was rendered with."""

from __future__ import annotations

from pathlib import Path

import pytest

from ares.protocol import load_scan
from ares.rig.factory import build_bench
from ares.scan import Runner
from ares.scan import events as ev
from wire_small import small_wire

# exposure x gain constant on the lit stages: a frame of the old settings has the new one's mean,
# a frame half old, half new has not; each stage changes a two-register exposure and the gain
STAGES = ((0.008, 1.0), (0.004, 2.0), (0.002, 4.0), (0.008, 1.0))


def _scan(tmp_path: Path, hold: bool) -> Path:
    system = small_wire(tmp_path, hold=hold)  # (sim_wire.xml declares one)
    stages = "\n".join(f'    <stage name="s{k}" scene="flat"><set quantity="exposure" value="{e}"/>'
                       f'<set quantity="analog_gain" value="{g}"/></stage>' for k, (e, g) in enumerate(STAGES))
    p = tmp_path / "hold_scan.xml"
    p.write_text(f"""<?xml version="1.0"?>
<scan name="hold" version="1">
  <system href="{system}"/>
  <settings><set quantity="light" value="2e5"/></settings>
  <frames>3</frames>
  <stages>
{stages}
    <stage name="dark" scene="dark"><set quantity="exposure" value="0.004"/><set quantity="analog_gain" value="2"/></stage>
  </stages>
  <output pdf="false" csv="false" hdf5="false"/>
</scan>
""")
    return p


def _run(scan_path: Path, in_flight: int = 1):
    scan = load_scan(scan_path)
    bench = build_bench(scan.system, seed=1, faults={"usb_frame_in_flight": in_flight})
    first = {}
    listen = (lambda e: first.setdefault(e.index, int(e.arrays["frame_counter"][0]))
              if isinstance(e, ev.StageFinished) else None)
    try:
        outcome = Runner(scan, bench=bench, listeners=(listen,)).run()
        return outcome, first, dict(bench.emulators["usb"].exposed_with)
    finally:
        bench.close()


@pytest.mark.parametrize("in_flight", [1, 2], ids=["latched_at_readout", "after_blanking"])
def test_a_stages_registers_latch_together_and_its_first_kept_frame_has_them_all(tmp_path, in_flight):
    """With the declared hold every stage's first kept frame was exposed with all of its settings
    (the device's record, not the host's), no frame the device sent mixes two stages' exposure and
    gain, and each stage records its change as atomic. Write-verify (sim_wire's verify="true") read
    the held registers back after the frame they latched at: the run is done -- also when the next
    frame starts only after a vertical blanking (``usb_frame_in_flight=2``), so that the read-back
    right after the frame in flight still finds the old values (it was a false write-verify error;
    a value not taken is now read again after the next frame)."""
    outcome, first, truth = _run(_scan(tmp_path, hold=True), in_flight)
    assert outcome.status == "done", outcome.message
    pairs = {(e, g) for e, g in STAGES} | {(0.01, 1.0), (0.004, 2.0)}  # (the power-up defaults)
    torn = {n: t for n, t in truth.items() if (t["exposure_s"], t["analog_gain"]) not in pairs}
    assert not torn, torn
    for st in outcome.stages:
        s, seen = st["settings"], truth[first[st["index"]]]
        assert (seen["exposure_s"], seen["analog_gain"], seen["photon_flux"]) == (
            pytest.approx(s["exposure"]), s["analog_gain"], s["light"]), (st["name"], seen)
        rec = st["settling"]["flat"]["registers"]
        assert rec["atomic"] is True and "group hold (register 0x0104)" in rec["how"]
    # the change was seen at the right frame: the frame in flight was the old stage's, and settling
    # did not keep it (its mean agrees with the new stage's: the settings, not the mean, tell)
    stale = [n for n in truth if n < max(first.values()) and truth[n]["exposure_s"] != truth[n + 1]["exposure_s"]]
    assert stale, "the device delivered no frame latched before a change"


def test_without_a_declared_hold_the_stage_says_its_writes_were_not_atomic(tmp_path):
    outcome, first, truth = _run(_scan(tmp_path, hold=False))
    assert outcome.status == "done", outcome.message
    for st in outcome.stages:
        rec = st["settling"]["flat"]["registers"]
        assert rec == {"fields": ["exposure", "analog_gain"], "atomic": False, "how": rec["how"]}
        assert "declares no <group_hold>" in rec["how"]


def test_two_fields_of_one_register_changed_in_one_hold_both_take_effect():
    """Inside a hold the device still reads a register's old value until the latch, so the second
    field's read-modify-write must start from what the first wrote, not from the device: both
    fields' new values latch at the next frame start (the emulated sensor's registers)."""
    from ares.hardware.emulators.i2c_device import EmulatedSMBus
    from ares.hardware.emulators.sensor_registers import SensorRegisters
    from ares.hardware.i2c import I2CRegisterBus
    from ares.hardware.registers import Field, RegisterFile, RegisterMap
    from ares.sim.bench import SimRegisterBus

    coarse, fine = Field("gain_coarse", 0x0020, 0, 3, maximum=15), Field("gain_fine", 0x0020, 4, 7, maximum=15)
    m = RegisterMap(16, 16, "big", (coarse, fine, Field("exposure", 0x0010, 0, 31, count=2)), group_hold=(0x0104, 1, 0))
    dev = SensorRegisters(m, SimRegisterBus(m))
    regs = RegisterFile(m, I2CRegisterBus(1, 0x36, 16, 16, smbus=EmulatedSMBus(0x36, dev), verify=True))
    rec = regs.set_many({"exposure": 0x0003_0004, "gain_coarse": 5, "gain_fine": 9})
    assert rec["atomic"] is True and dev.inner.read(0x20) == 0 and dev.inner.read(0x10) == 0  # held, not latched
    dev.frame_boundary()
    regs.bus.verify_pending()  # (held writes read back after the frame they latched at)
    assert dev.inner.read(0x20) == 9 << 4 | 5 and regs.get_raw("exposure") == 0x0003_0004
    assert regs.get("gain_coarse") == 5 and regs.get("gain_fine") == 9
    with pytest.raises(Exception, match="above its maximum"):  # every value checked before the hold opens
        regs.set_many({"gain_coarse": 1, "gain_fine": 16})
    assert not dev.holding and dev.held == {} and dev.pending == {}  # nothing written


def test_settling_by_tags_discards_the_frame_latched_before_the_hold_closed(tmp_path):
    """A streaming sensor that tags each frame with the exposure it was exposed with (chunk data,
    embedded lines) and latches a held change at the next frame start, which begins as the frame in
    flight is read out. Settling by tags sees the change at the right frame: the frame in flight
    (latched before the hold closed: the old exposure) is discarded by its tag, though its mean
    agrees, and the register read back for the comparison is the latched new value."""
    import numpy as np

    from ares.hardware.emulators.i2c_device import EmulatedSMBus
    from ares.hardware.emulators.sensor_registers import SensorRegisters
    from ares.hardware.i2c import I2CRegisterBus
    from ares.hardware.interfaces import Bench, Frame
    from ares.hardware.registers import RegisterFile
    from ares.protocol import load_system
    from ares.scan.apply import apply_settings
    from ares.sim.bench import SimRegisterBus
    from ares.sim.strict import SimClock

    system = load_system(small_wire(tmp_path))  # (sim_wire.xml declares its sensor's group hold)
    dev = SensorRegisters(system.registers, SimRegisterBus(system.registers))
    regs = RegisterFile(system.registers, I2CRegisterBus(1, 0x36, 16, 16, smbus=EmulatedSMBus(0x36, dev)))
    exposure = system.registers.field("exposure")

    class Streaming:  # the next frame starts, latching the registers, as one is read out
        name, shape, n = "streaming sensor", (8, 8), 0

        def grab(self, k):
            for _ in range(k):
                self.n += 1
                raw = dev.inner.read(0x10) << 16 | dev.inner.read(0x11)  # what this frame was latched with
                yield Frame(np.full(self.shape, 200, np.uint16), self.n, 0.0,
                            {"exposure_s": exposure.to_physical(raw)})
                dev.frame_boundary()

    bench = Bench(regs, Streaming(), clock=SimClock())
    list(bench.frames.grab(2))
    rec = apply_settings(bench, system, {"exposure": 0.004}, {"exposure": 0.01})
    assert rec["registers"]["atomic"] is True
    assert rec["settled"] is True and rec["by"] == "tags+frames", {k: rec[k] for k in ("why", "probe_frames")}
    assert rec["probe_frames"] == 4  # the frame in flight (old exposure) and three that agree
