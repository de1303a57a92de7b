"""Peak memory of ``ares analyze`` and ``ares defects`` against the stack length.

Both commands stream their input frame by frame (``ares.hardware.stackfiles``), so their
peak resident memory must not grow with the number of frames. Measured: each command in
its own process (peak RSS from ``wait4``) on a 1080p uint16 dark stack of F and 10 F frames
(.npy files on disk), next to the baseline of the same process doing nothing but import
ARES and numpy. Writes benchmarks/stream_memory.md.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

ROOT = Path(__file__).resolve().parents[1]
R, C, F = 1080, 1920, 20


def write_stack(path: Path, frames: int, seed: int = 0) -> None:
    """A dark stack with a few hot pixels, written in chunks (never whole in memory)."""
    rng = np.random.default_rng(seed)
    base = (200 + rng.normal(0, 2, (R, C))).astype(np.float32)
    hot = rng.integers(0, R * C, 200)
    mm = np.lib.format.open_memmap(path, mode="w+", dtype=np.uint16, shape=(frames, R, C))
    for i in range(frames):
        f = base + rng.normal(0, 3, (R, C)).astype(np.float32)
        f.flat[hot] += 500
        mm[i] = np.clip(np.rint(f), 0, 4095).astype(np.uint16)
    mm.flush()
    del mm


# The child reports its own high-water mark (VmHWM of its address space after exec): the
# rusage maxrss of a forked child would include the parent's memory at the fork.
_PROBE = """
import sys
code = 0
try:
    args = sys.argv[1:]
    if args[0] == "-c":
        exec(args[1])
    else:
        from ares.cli import main
        code = main(args)
finally:
    hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
    sys.stderr.write("VmHWM_kB " + hwm + "\\n")
sys.exit(code)
"""


def peak_rss_mb(argv: list[str]) -> float:
    p = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True, cwd=ROOT)
    if p.returncode not in (0, 4):  # 4: defect limits (none set here)
        raise SystemExit(f"{argv}: failed: {p.stderr}")
    return int(p.stderr.strip().splitlines()[-1].split()[1]) / 1024.0


def main() -> int:
    ares = []
    rows = []
    with tempfile.TemporaryDirectory() as td:
        small, big = Path(td) / "dark_f.npy", Path(td) / "dark_10f.npy"
        write_stack(small, F)
        write_stack(big, 10 * F)
        base = peak_rss_mb(["-c", "import numpy, scipy, ares.analysis.noise.decompose"])
        for name, args in (("analyze", ["analyze"]), ("defects", ["defects", "--dark"])):
            a = peak_rss_mb(ares + args + [str(small)])
            b = peak_rss_mb(ares + args + [str(big)])
            rows.append((name, a, b))
    desc = ROOT.parent / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / "EMVA1288_Data.txt"
    emva = peak_rss_mb(ares + ["emva", str(desc)]) if desc.is_file() else None
    stack_mb = R * C * 2 * 10 * F / 2**20
    lines = ["## Streaming memory: `ares analyze` and `ares defects` vs stack length", "",
             f"1080p uint16 dark stack as .npy, {F} and {10 * F} frames ({stack_mb:.0f} MiB); peak resident memory "
             f"of the command's process. Baseline: a process importing numpy, scipy and ARES's analysis: "
             f"{base:.0f} MiB.", "",
             f"| command | {F} frames, MiB | {10 * F} frames, MiB | ratio 10x / 1x | above baseline, 1x / 10x |",
             "|---|---:|---:|---:|---:|"]
    for name, a, b in rows:
        lines.append(f"| ares {name} | {a:.0f} | {b:.0f} | {b / a:.3f} | {a - base:.0f} / {b - base:.0f} |")
    if emva is not None:
        lines += ["", f"`ares emva` on the EMVA 1288 reference CCD (300 PNGs of 640x480, spatial levels of 50 "
                  f"frames, streamed): peak {emva:.0f} MiB, {emva - base:.0f} MiB above the baseline (395 MiB "
                  "before the spatial statistics were streamed)."]
    return publish("stream_memory", lines)


if __name__ == "__main__":
    sys.exit(main())
