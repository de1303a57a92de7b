"""What ``ares run`` checks before it touches hardware, in one place: ``ares validate`` and
``ares run --dry-run`` call the same function, so whatever a run would refuse they refuse
first (the static checks, with file:line, are in ``ares.protocol.load_scan``; these are
the ones that depend on the run's arguments and on this machine).

The memory estimate is measured, not derived (``benchmarks/bench_estimates.py``: every
shipped scan and two 4096x3072 scans, each within 10 % of its measured peak), for numba's
kernels cached as ``make`` installs them (``python -m ares.jit``) -- the usual case, and
the one the note names; a first run, which compiles them in the run, peaks 20-53 MiB higher
(``COMPILE_BYTES``: 34 MiB; 20-53, mean 36, over six scans measured with an empty cache,
``--cold``), and ``ares.analysis.kernels.jit.kernels_cached`` tells which case this machine is in without
importing numba. The parts: the interpreter with numpy/scipy/h5py/numba and the report's
plotting (~250 MiB: ``mtf.xml`` on 128x200 peaks at 253 MiB); about 127 bytes per pixel
of the full view (the accumulators, the simulator's maps, the analyses' float64 maps and
the report: photon_transfer at 4096x3072 less the same scan at 640x480, before the
masked-stage term below); the first dark stage's frames, kept to mask that stage (2
bytes per pixel each, in memory up to ``KEEP_FOR_MASK_BYTES``, ``ares.scan.kept``), at a
time when the rest holds about 90 bytes per pixel; what each scan-level analysis adds
(its modules, tables and report pages, measured on the shipped scans, ``ANALYSIS_BYTES``);
and what folding many frames against the defect mask adds (the stages after the first
dark one, ``masked_heap_bytes``): at 640x480 the freed heap ``ares.malloc`` keeps,
144-213 MiB in the four shipped scans with 184-400 such frames, none with 14-50 (the same
without the defects analysis and at 25 C; which temporaries fragment the heap is not
isolated), at 4096x3072 55 bytes per pixel. Regions and channel views add their own
accumulators (100 bytes per pixel they cover, not re-measured here). (It was 0.93 kB per
pixel before the accumulators shared their per-pixel sums, 200 B before the stage
analyses stopped caching maps they use once; the constants were read off first runs,
compiling, until issue 41's refit.)
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass
from pathlib import Path

from ares.errors import InputError, StorageError
from ares.scan.stages import Stage, expand

MAX_FRAMES = 100000  # the scan schema's <frames> maximum
MAX_SEED = 2**63 - 1
# the interpreter with the libraries a run imports: measured at install (ares.memory_base), else
# this (measured 2026-11-29 with numpy 2.4, numba 0.68, matplotlib 3.11: 242 MiB with the page
# cache warm, 170 MiB after it was emptied: the larger, so that the estimate errs high)
IMPORT_BYTES = 254e6
RUN_BYTES = 60e6  # on top of the imports: numba's kernels loaded from the cache, the report's plotting
BYTES_PER_PIXEL = 127.0  # full view: accumulators, simulator maps, the analyses' float64 maps and the report
FIRST_DARK_BYTES_PER_PIXEL = 90.0  # the same while the first dark stage's frames are kept (they come on top)
ANALYSIS_BYTES = {"ptc": 15e6, "defects": 35e6, "dark_current": 20e6, "emva4": 62e6, "photon_counting": 46e6,
                  "adc_linearity": 26e6, "lag": 40e6, "gain_split": 6e6}  # measured, bench_estimates.py
COMPILE_BYTES = 36e6  # a first run: numba compiling its kernels in the run (20-53 MiB over 6 scans, --cold)
PRECISION_BYTES = 40e6  # a precision-driven scan: the pilot's results kept beside the run's
MASKED_HEAP_BYTES = 86e6  # freed heap kept while >= MASKED_FRAMES masked frames are folded, 640x480, beside the held stages
MASKED_BYTES_PER_PIXEL = 55.0  # the same on large frames, their heap trimmed at 32 MB (one row: 4096x3072)
MASKED_FRAMES = 100  # measured: 14, 32 and 50 masked frames add nothing, 184, 256 and 400 all of it
BYTES_PER_VIEW_PIXEL = 100.0  # each further view (region, Bayer phase, ADC channel) per pixel it covers
KEEP_FOR_MASK_BYTES = 256 * 1024 * 1024  # the first dark stage's frames kept in memory up to this size
# the stages kept until a flat completes the defect mask (ares.scan.mask_complete): their
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
    disk_bytes: float = 0.0
    disk_free: float | None = None  # free bytes in disk_folder, None when unknown
    disk_folder: Path | None = None
    kernels_cached: bool = True  # the case the memory estimate assumes (``ares.analysis.kernels.jit.kernels_cached``)
    base_measured: bool = True  # the libraries' memory measured on this machine (``ares.memory_base``)

    def disk_fits(self) -> bool:
        return self.disk_free is None or self.disk_bytes <= self.disk_free

    def disk_note(self) -> str:
        """One line: the run directory's size against the free space where it goes."""
        need = f"disk: about {_gb(self.disk_bytes)}"
        if self.disk_free is None:
            return need
        if not self.disk_fits():
            return f"{need}, more than the {_gb(self.disk_free)} free in {self.disk_folder}"
        return f"{need} of the {_gb(self.disk_free)} free in {self.disk_folder}"

    def memory_note(self) -> str:
        """One line for ``--dry-run`` and ``validate``: the estimate against this machine."""
        gb = self.memory_bytes / 1e9
        case = ("numba kernels cached" if self.kernels_cached else
                "a first run: numba compiles its kernels in it, `python -m ares.jit` caches them first")
        if not self.base_measured:
            case += (" (the libraries' share assumed, not measured on this machine: `python -m ares.jit` "
                     "measures it)" if self.kernels_cached else " and measures the libraries' share")
        if self.memory_available is not None and self.memory_bytes > self.memory_available:
            return (f"memory: about {gb:.1f} GB, {case}, more than the {self.memory_available / 1e9:.1f} GB "
                    "available now (the run may swap)")
        return f"memory: about {gb:.1f} GB, {case}"


def memory_bytes(scan, stages: list[Stage], kernels_cached: bool | None = None,
                 import_bytes: float | None = None) -> float:
    """Peak resident memory of ``ares run`` for ``scan`` (the measured model above), with
    numba's kernels loaded from its cache or, ``kernels_cached=False``, compiled in the run
    (None: as ``ares.analysis.kernels.jit.kernels_cached`` finds this machine); ``import_bytes``: the
    libraries' share measured now (None: as recorded at install, ``base_bytes``)."""
    if kernels_cached is None:
        from ares.analysis.kernels.jit import kernels_cached as cached_here

        kernels_cached = cached_here()
    s = scan.system.sensor
    px = float(s.rows) * float(s.cols)
    extra = sum(float(r.width) * float(r.height) for r in scan.regions)
    extra += px * ((s.cfa != "mono") + (s.adc_channels > 1))
    kept = min(2.0 * px * next((st.frames for st in stages if st.scene == "dark"), 0), KEEP_FOR_MASK_BYTES)
    fixed = base_bytes(import_bytes) + sum(ANALYSIS_BYTES.get(a, 0.0) for a in set(scan.analyses))
    fixed += PRECISION_BYTES if scan.precision is not None else 0.0
    fixed += 0.0 if kernels_cached else COMPILE_BYTES
    fixed += masked_heap_bytes(px, stages)
    held = min(sum(HELD_BYTES_PER_PIXEL * (px + extra) + 2.0 * px * st.frames_to_grab()
                   for st in held_stages(stages)), HOLD_MAX_BYTES + KEEP_FOR_MASK_BYTES)
    return (fixed + max(BYTES_PER_PIXEL * px, FIRST_DARK_BYTES_PER_PIXEL * px + kept) + BYTES_PER_VIEW_PIXEL * extra
            + held)


def held_stages(stages: list[Stage]) -> list[Stage]:
    """The stages a run holds (their sums and kept frames, ``ares.scan.mask_complete``)
    until a flat completes the defect mask: those after the first dark stage up to the flat
    that does it -- a flat with a matched dark, assumed the first third of such flats in (a
    rising sweep's dim end does not show the flat classes: photon_transfer.xml completes at
    its 9th of 25) -- or all of them when no flat has a matched dark (lag.xml)."""
    first = next((k for k, st in enumerate(stages) if st.scene == "dark"
                  and st.settings.get("reg:test_mode", 0) == 0), None)
    if first is None or not any(st.scene == "flat" for st in stages[first + 1:]):
        return []  # no later flat: the first dark's mask is the run's at once
    after = stages[first + 1:]
    can = [k for k, st in enumerate(after) if st.scene == "flat" and st.dark_source != "none"]
    if not can:
        return after
    return after[:can[math.ceil(len(can) / 3) - 1] + 1]


def base_bytes(measured: float | None = None) -> float:
    """What any run takes before its pixels: the libraries' import (``measured``, else as
    measured on this machine at install where it could be, ``ares.memory_base``) and
    ``RUN_BYTES``. (Their resident pages vary with the machine's state, the page cache: 170
    to 242 MiB on one machine in one day; the install's figure is what the estimate has.)"""
    from ares.memory_base import recorded

    measured = recorded() if measured is None else measured
    return (IMPORT_BYTES if measured is None else float(measured)) + RUN_BYTES


def masked_heap_bytes(px: float, stages: list[Stage]) -> float:
    """What folding many frames against the defect mask (the stages after the first dark
    one) adds. Small frames: the freed heap ``ares.malloc`` keeps (up to its 256 MB trim
    threshold), ``MASKED_HEAP_BYTES`` at 640x480, in proportion to the frame below that
    and at most the trim threshold above it (only 640x480 measured). Large frames (their
    heap is trimmed at 32 MB): ``MASKED_BYTES_PER_PIXEL``, from photon_transfer at
    4096x3072 (128 masked frames: 2.42 GiB, 1.82 GiB estimated without it)."""
    from ares.malloc import LARGE_FRAME_PIXELS

    first = next((k for k, st in enumerate(stages) if st.scene == "dark"
                  and st.settings.get("reg:test_mode", 0) == 0), None)
    masked = sum(st.frames_to_grab() for st in stages[first + 1:]) if first is not None else 0
    if masked < MASKED_FRAMES:
        return 0.0
    if px > LARGE_FRAME_PIXELS:
        return MASKED_BYTES_PER_PIXEL * px
    if not held_stages(stages):  # measured: temperature.xml (184 masked frames, no flat) keeps none
        return 0.0
    return min(MASKED_HEAP_BYTES * px / (640 * 480), 256 * 2**20)


STAGE_BYTES_PER_PIXEL = 12.0  # stages/NNNN.h5: float32 mean and variance maps, a matched dark's mean
STAGE_BYTES = 64e3  # each stage's JSON and HDF5 overhead
REPORT_BYTES = 4e6  # report.pdf, report.h5, the CSV tables and run.json of a small sensor
REPORT_BYTES_PER_PIXEL = 4.0  # maps in the reports


def disk_bytes(scan, stages: list[Stage]) -> float:
    """Bytes the run directory will hold at its largest: the raw frames it keeps
    (``<output raw_frames>``, uint16), the first dark stage's frames beyond
    ``KEEP_FOR_MASK_BYTES`` (a temporary file beside the run while that stage is masked),
    the stages' HDF5 and JSON and the reports."""
    s = scan.system.sensor
    px = float(s.rows) * float(s.cols)
    frame = 2.0 * px
    raw = frame * sum(st.frames_to_grab() for st in stages) if scan.output.raw_frames else 0.0
    kept = max(0.0, frame * next((st.frames for st in stages if st.scene == "dark"), 0) - KEEP_FOR_MASK_BYTES)
    return raw + kept + len(stages) * (STAGE_BYTES + STAGE_BYTES_PER_PIXEL * px) + REPORT_BYTES + \
        REPORT_BYTES_PER_PIXEL * px


def _gb(b: float) -> str:
    return f"{b / 1e9:.1f} GB" if b >= 0.95e8 else f"{b / 1e6:.0f} MB"


def out_folder(out_dir) -> Path:
    """The existing folder a run directory for ``--out out_dir`` is made in (its disk):
    the nearest existing one of out_dir and its parents (``runs/`` without --out)."""
    p = Path(out_dir if out_dir is not None else "runs").absolute()
    while not p.is_dir() and p != p.parent:
        p = p.parent
    return p


def disk_free(folder: Path) -> float | None:
    try:
        return float(shutil.disk_usage(folder).free)
    except OSError:
        return None


def machine_memory() -> tuple[float | None, float | None]:
    """(total, available) physical memory in bytes (``ares.safefile.machine_memory``: every
    reader's size check asks the same)."""
    from ares.safefile import machine_memory as mm

    return mm()


def check_run(scan, frames: int | None = None, seed: int | None = None, out_dir=None, refuse_disk: bool = True) -> Plan:
    """Refuse (``InputError``, one sentence) what the run would fail on later: the frame
    override, the seed, the simulator's parameters, the memory the scan needs; and
    (``StorageError``, exit 5; only noted when not ``refuse_disk``) a run directory larger
    than the free space of the folder ``--out out_dir`` puts it in."""
    where = scan.source or scan.name
    if frames is not None and not 2 <= frames <= MAX_FRAMES:
        raise InputError(f"--frames must be an integer from 2 to {MAX_FRAMES}, got {frames}")
    if seed is not None and not 0 <= seed <= MAX_SEED:
        raise InputError(f"--seed must be an integer from 0 to 2**63-1, got {seed}")
    stages = expand(scan, frames)
    if scan.system.simulator is not None:
        from ares.sim.from_system import sim_params

        sim_params(scan.system)
    if scan.system.replay is not None:  # recorded data: there, readable, of the declared sensor
        from ares.hardware.replay import replay_descriptor

        replay_descriptor(scan.system)
    from ares.analysis.kernels.jit import kernels_cached

    cached = kernels_cached()
    need = memory_bytes(scan, stages, cached)
    total, avail = machine_memory()
    if total is not None and need > total:
        s = scan.system.sensor
        raise InputError(f"{where}: the scan needs about {need / 1e9:.1f} GB of memory ({s.cols}x{s.rows} pixels, "
                         f"{len(scan.regions)} region(s), {max(st.frames for st in stages) if stages else 0} frames "
                         f"per stage at most) but this machine has {total / 1e9:.1f} GB; use a smaller array or "
                         "fewer or smaller regions")
    folder = out_folder(out_dir)
    from ares.memory_base import recorded

    plan = Plan(stages, need, total, avail, disk_bytes(scan, stages), disk_free(folder), folder, cached,
                recorded() is not None)
    if refuse_disk and not plan.disk_fits():
        raise StorageError(f"{folder}: the run needs about {_gb(plan.disk_bytes)} of disk "
                           f"({'raw frames kept, ' if scan.output.raw_frames else ''}stage files and reports) "
                           f"but only {_gb(plan.disk_free)} is free there")
    return plan
