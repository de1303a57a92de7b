"""Bounded recovery (issue 36, finding 2) on protocols/sim_wire.xml: a device that fails
during a scan with ``<suspend><condition quantity="device"/>`` is reopened -- the one that
failed, not another -- with a growing pause; a device that stays away or keeps failing ends
the run "failed" with exit 3 and a truthful run.json; stop and SIGTERM end a recovery.

Before the change the I2C disconnect below reopened the USB grabber and retried the stage
forever (100 % CPU, SIGTERM ignored, run.json "running"). The waits on processes and
threads here are hang detectors (``HANG_S``), never speed assertions."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from ares.errors import HardwareError
from ares.rig.factory import build_bench
from ares.rig.wire import wire_faults
from ares.protocol import load_scan
from ares.scan import Runner
from ares.scan import events as ev
from wire_small import small_wire

ROOT = Path(__file__).resolve().parents[1]
WIRE = ROOT / "protocols" / "sim_wire.xml"
HANG_S = 300  # only a hang detector: a run that takes this long is stuck
I2C_AT = 77  # the third stage's sf_bias write (sf_bias set before each stage inside sim_wire's group hold, the
# exposure's upper register read again after its two; the first two transactions are the chip-ID read and the
# <init> write at connect)


def _scan(tmp_path: Path, timeout_s: float = 2, max_recoveries: int = 5, chamber: bool = False,
          small: bool = False) -> Path:
    p = tmp_path / "recover.xml"
    system = small_wire(tmp_path) if small else WIRE
    warm = '<stage name="warm" scene="dark"><set quantity="temperature" value="30"/></stage>' if chamber else ""
    p.write_text(f"""<?xml version="1.0"?>
<scan name="recover" version="1">
  <system href="{system}"/>
  <settings><set quantity="exposure" value="0.01"/><set field="sf_bias" value="1.6"/></settings>
  <frames>2</frames>
  <stages>
    <stage name="dark" scene="dark"/>
    <sweep name="ptc" scene="flat"><axis quantity="light"><values>1e4 1e5 1e6</values></axis></sweep>
    {warm}
  </stages>
  <suspend poll_s="0.02" hold_s="0" timeout_s="{timeout_s}" max_recoveries="{max_recoveries}">
    <condition quantity="device"/>
  </suspend>
  <output pdf="false"/>
</scan>
""")
    return p


def _cli(scan: Path, out: Path, *faults: str) -> subprocess.Popen:
    args = [a for f in faults for a in ("--sim-fault", f)]
    return subprocess.Popen([sys.executable, "-m", "ares.cli", "run", str(scan), "--out", str(out), "-q", *args],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})


def _status(out: Path) -> dict:
    return json.loads((out / "run.json").read_text())


def test_an_i2c_sensor_that_stays_away_fails_the_run_truthfully(tmp_path):
    out = tmp_path / "run"
    p = _cli(_scan(tmp_path, timeout_s=0.5), out, f"i2c_disconnect_at={I2C_AT}")
    _, err = p.communicate(timeout=HANG_S)
    assert p.returncode == 3, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err
    assert "I2C device 0x36 on bus 1 ('sensor')" in lines[0] and "not back after 0.5 s" in lines[0]
    meta = _status(out)
    assert meta["status"] == "failed" and meta["stages_completed"] == 2


def _in_process(tmp_path, faults: dict, **scan_kw):
    """Run the scan on a wire bench in a thread (joined with the hang bound): the outcome or
    the exception, the bench's emulators, how often each bench part was reopened."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    scan = load_scan(_scan(tmp_path, **scan_kw))
    bench = build_bench(scan.system, seed=1, faults=faults)
    opened = {"frames": 0, "registers": 0, "light": 0}
    for part, dev in (("frames", bench.frames), ("registers", bench.registers.bus), ("light", bench.light)):
        orig = dev.reconnect

        def counted(orig=orig, part=part):
            opened[part] += 1
            return orig()

        dev.reconnect = counted
    runner = Runner(scan, bench=bench, out_dir=tmp_path / "run")
    box = {}

    def go():
        try:
            box["outcome"] = runner.run()
        except Exception as exc:  # noqa: BLE001 -- handed to the test
            box["error"] = exc

    t = threading.Thread(target=go, daemon=True)
    return runner, bench, opened, box, t


def test_the_device_that_failed_is_reopened_not_the_grabber(tmp_path):
    runner, bench, opened, box, t = _in_process(tmp_path, {"i2c_disconnect_at": I2C_AT, "i2c_gone_for": 4})
    t.start()
    t.join(HANG_S)
    bench.close()
    assert not t.is_alive() and "error" not in box, box
    assert box["outcome"].status == "done"
    # gone for transactions 77..80: the write, the hold's release and two probes fail, the third probe answers
    assert opened == {"frames": 0, "registers": 3, "light": 0}
    sus = [s for st in box["outcome"].stages for s in st.get("suspensions", [])]
    assert [(s["device"], s["attempts"]) for s in sus] == [("registers", 3)]
    assert "register 0x0050" in sus[0]["reason"]  # sf_bias, the write that found the sensor gone


def test_a_sensor_gone_while_the_registers_are_read_is_recovered(tmp_path):
    """The register snapshots at a stage's start and end read the sensor too: gone there, it
    is reconnected and the stage acquired again (both were outside the recovery: the run
    failed). The transaction is found from a clean run's link statistics."""
    from ares.cli import main

    clean = tmp_path / "clean"
    assert main(["run", str(_scan(tmp_path, small=True)), "--out", str(clean), "-q"]) == 0
    per_stage = [json.loads((clean / "stages" / f"{k:04d}.json").read_text())["link"]["registers"]["transactions"]
                 for k in range(3)]
    last_read_of_stage_1 = 2 + per_stage[0] + per_stage[1] - 1  # (2: the chip-ID read and <init> at connect)
    for at in (last_read_of_stage_1, last_read_of_stage_1 + 1):  # its end snapshot; stage 2's first snapshot read
        runner, bench, opened, box, t = _in_process(tmp_path / str(at), {"i2c_disconnect_at": at, "i2c_gone_for": 2},
                                                    small=True)
        t.start()
        t.join(HANG_S)
        bench.close()
        assert not t.is_alive() and "error" not in box, box
        assert box["outcome"].status == "done" and opened["registers"] == 2 and opened["frames"] == 0
        sus = [s for st in box["outcome"].stages for s in st.get("suspensions", [])]
        assert len(sus) == 1 and "device gone on read" in sus[0]["reason"], sus


def test_a_device_that_keeps_failing_ends_at_max_recoveries(tmp_path):
    """Every reconnect succeeds and every stage attempt fails again: the original endless loop."""
    runner, bench, opened, box, t = _in_process(tmp_path, {}, max_recoveries=2)
    bus = bench.registers.bus
    write = bus.write

    def flaky(address, value, **kw):
        if address == 0x0050 and bench.emulators["i2c"].transactions > I2C_AT:
            from ares.errors import DeviceGone

            raise DeviceGone("I2C device 0x36: no acknowledge", "registers")
        return write(address, value, **kw)

    bus.write = flaky
    t.start()
    t.join(HANG_S)
    bench.close()
    assert not t.is_alive()
    assert isinstance(box.get("error"), HardwareError) and "max_recoveries=2" in str(box["error"]), box
    assert opened["registers"] == 2 and opened["frames"] == 0
    assert _status(tmp_path / "run")["status"] == "failed"


def test_stop_ends_a_recovery_that_would_wait_ten_minutes(tmp_path):
    runner, bench, opened, box, t = _in_process(tmp_path, {"i2c_disconnect_at": I2C_AT}, timeout_s=600)
    runner.add_listener(lambda e: runner.stop() if isinstance(e, ev.Paused) else None)
    t.start()
    t.join(HANG_S)
    bench.close()
    assert not t.is_alive() and "error" not in box, box
    assert box["outcome"].status == "stopped" and len(box["outcome"].stages) == 2
    assert _status(tmp_path / "run")["status"] == "stopped"


def test_sigterm_during_recovery_stops_the_run(tmp_path):
    out = tmp_path / "run"
    p = _cli(_scan(tmp_path, timeout_s=600), out, f"i2c_disconnect_at={I2C_AT}")
    while not (out / "stages" / "0001.json").exists():  # the fault is in the next stage
        assert p.poll() is None, p.communicate()
        threading.Event().wait(0.05)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=HANG_S)
    assert p.returncode == 130, err
    assert _status(out)["status"] == "stopped"


CAMPAIGN = [k for k in wire_faults() if k.endswith("_at")]
POSITIONS = {"usb": (0, 3, 7), "i2c": (5, I2C_AT, 120), "light": (1, 2, 4), "chamber": (1, 2, 3)}

# every case of a device runs in one process, one after another (ares.cli.main per case): the
# process start and the kernels' warm-up (~8 s on a busy machine) once per device, each case
# ~1 s after it; the process is the hang detector
_DRIVER = """
import contextlib, io, json, sys
from ares.cli import main
scan, out = sys.argv[1:3]
for case in sys.argv[3:]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = main(["run", scan, "--out", f"{out}/{case}", "-q", "--sim-fault", case])
    print(json.dumps({"case": case, "rc": rc, "err": err.getvalue()}), flush=True)
"""


@pytest.mark.slow
@pytest.mark.parametrize("device", [d if d == "usb" else pytest.param(d, marks=pytest.mark.study)
                                    for d in sorted(POSITIONS)])  # usb in the suite, the rest in bench-quick
def test_fault_campaign_every_kind_ends_in_0_or_3(device, tmp_path):
    """Each fault kind of the device at three positions (frame / transaction / command
    counts): the run recovers within the limits (exit 0) or fails truthfully (exit 3), never
    hangs; on sim_wire.xml at 48x64 pixels."""
    cases = [f"{k}={at}" for k in CAMPAIGN if k.startswith(device + "_") for at in POSITIONS[device]]
    scan = _scan(tmp_path, timeout_s=0.3, chamber=True, small=True)
    p = subprocess.Popen([sys.executable, "-c", _DRIVER, str(scan), str(tmp_path / "runs"), *cases], cwd=ROOT,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    out, err = p.communicate(timeout=HANG_S * len(cases))
    assert p.returncode == 0, err
    done = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    assert [c["case"] for c in done] == cases, out
    outcomes = set()
    for c in done:
        assert c["rc"] in (0, 3), c
        meta = _status(tmp_path / "runs" / c["case"])
        assert meta["status"] == ("done" if c["rc"] == 0 else "failed"), (c, meta["status"])
        if c["rc"] == 3:
            assert len(c["err"].strip().splitlines()) == 1 and "Traceback" not in c["err"], c
        outcomes.add(c["rc"])
    assert 3 in outcomes  # the faults landed: some failed the run (every light fault does: no retries declared)
