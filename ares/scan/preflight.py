"""What ``ares run`` checks before it touches hardware, in one place: ``ares validate`` and
``ares run --dry-run`` call the same function, so whatever a run would refuse they refuse
first (the static checks, with file:line, are in ``ares.protocol.load_scan``; these are
the ones that depend on the run's arguments and on this machine).

The memory estimate is measured, not derived: the shipped photon-transfer scan on a
simulated 4096x3072 sensor (``benchmarks/bench_big_memory.py``) peaks at about 105 bytes
per pixel above the interpreter and its libraries, plus the frames of the first dark stage
(2 bytes per pixel each, kept to mask that stage too: in memory up to ``KEEP_FOR_MASK_BYTES``,
the rest in a temporary file, ``ares.scan.kept``); the model adds a third for margin. Regions and
channel views add their own accumulators. (It was 0.93 kB per pixel before the
accumulators shared their per-pixel sums, 200 B before the stage analyses stopped caching
maps they use once.)
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from ares.errors import InputError
from ares.scan.stages import Stage, expand

MAX_FRAMES = 100000  # the scan schema's <frames> maximum
MAX_SEED = 2**63 - 1
BASE_BYTES = 300e6  # the interpreter, numpy/scipy/h5py and the report's plotting
BYTES_PER_PIXEL = 140.0  # full view: accumulators, simulator maps, the analyses' float64 maps and the report
BYTES_PER_VIEW_PIXEL = 100.0  # each further view (region, Bayer phase, ADC channel) per pixel it covers
KEEP_FOR_MASK_BYTES = 256 * 1024 * 1024  # the first dark stage's frames kept in memory up to this size
# the stages held until a flat completes the defect mask (ares.scan.runner._hold): their
# sums (~16 B a pixel a stage, measured on VGA) up to this, then the mask is completed
HOLD_MAX_BYTES = 256 * 1024 * 1024
HELD_BYTES_PER_PIXEL = 16.0


def held_bytes(stacks) -> int:
    """Bytes of the accumulators of the ``StackSet``s held (each counted once)."""
    seen = {id(ss): ss for ss in stacks}
    return sum(acc.nbytes() for ss in seen.values() for acc in ss.acc.values())


@dataclass(frozen=True)
class Plan:
    stages: list[Stage]
    memory_bytes: float
    memory_total: float | None  # this machine's physical memory, None when unknown
    memory_available: float | None

    def memory_note(self) -> str:
        """One line for ``--dry-run`` and ``validate``: the estimate against this machine."""
        gb = self.memory_bytes / 1e9
        if self.memory_available is not None and self.memory_bytes > self.memory_available:
            return (f"memory: about {gb:.1f} GB, more than the {self.memory_available / 1e9:.1f} GB available now "
                    "(the run may swap)")
        return f"memory: about {gb:.1f} GB"


def memory_bytes(scan, stages: list[Stage]) -> float:
    """Peak resident memory of ``ares run`` for ``scan`` (the measured model above)."""
    s = scan.system.sensor
    px = float(s.rows) * float(s.cols)
    extra = sum(float(r.width) * float(r.height) for r in scan.regions)
    extra += px * ((s.cfa != "mono") + (s.adc_channels > 1))
    kept = min(2.0 * px * next((st.frames for st in stages if st.scene == "dark"), 0), KEEP_FOR_MASK_BYTES)
    first_dark = next((k for k, st in enumerate(stages) if st.scene == "dark"), None)
    n_flat = 0 if first_dark is None else sum(st.scene == "flat" for st in stages[first_dark:])
    # held for the mask: about the first third of a flat sweep (its dim end) until a flat shows dead pixels
    held = min(HELD_BYTES_PER_PIXEL * (px + extra) * math.ceil(n_flat / 3), HOLD_MAX_BYTES) if n_flat else 0.0
    return BASE_BYTES + BYTES_PER_PIXEL * px + BYTES_PER_VIEW_PIXEL * extra + kept + held


def machine_memory() -> tuple[float | None, float | None]:
    """(total, available) physical memory in bytes, from /proc/meminfo or sysconf."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            info = {ln.split(":")[0]: float(ln.split()[1]) * 1024 for ln in f if ":" in ln}
        return info.get("MemTotal"), info.get("MemAvailable")
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")), None
    except (ValueError, OSError, AttributeError):
        return None, None


def check_run(scan, frames: int | None = None, seed: int | None = None) -> Plan:
    """Refuse (``InputError``, one sentence) what the run would fail on later: the frame
    override, the seed, the simulator's parameters, the memory the scan needs."""
    where = scan.source or scan.name
    if frames is not None and not 2 <= frames <= MAX_FRAMES:
        raise InputError(f"--frames must be an integer from 2 to {MAX_FRAMES}, got {frames}")
    if seed is not None and not 0 <= seed <= MAX_SEED:
        raise InputError(f"--seed must be an integer from 0 to 2**63-1, got {seed}")
    stages = expand(scan, frames)
    if scan.system.simulator is not None:
        from ares.hardware.factory import sim_params

        sim_params(scan.system)
    if scan.system.replay is not None:  # recorded data: there, readable, of the declared sensor
        from ares.hardware.replay import replay_descriptor

        replay_descriptor(scan.system)
    need = memory_bytes(scan, stages)
    total, avail = machine_memory()
    if total is not None and need > total:
        s = scan.system.sensor
        raise InputError(f"{where}: the scan needs about {need / 1e9:.1f} GB of memory ({s.cols}x{s.rows} pixels, "
                         f"{len(scan.regions)} region(s), {max(st.frames for st in stages) if stages else 0} frames "
                         f"per stage at most) but this machine has {total / 1e9:.1f} GB; use a smaller array or "
                         "fewer or smaller regions")
    return Plan(stages, need, total, avail)
