"""The wire path: unpacking packed pixels, and the grabber path's cost against the direct
simulator. Writes benchmarks/wire.md.

1. ``ares.hardware.pixels.unpack`` on 1920x1080 frames in every format, one core; the
   baseline is a plain copy of the same output array (the memory-bus floor) measured in the
   same run. Target: Mono12p >= 1 GB/s of uint16 output.
2. ``protocols/sim_wire.xml`` vs ``protocols/sim_sensor.xml``: frames per second through
   the emulated USB grabber (Mono12p, ares32 header, payload CRC, pyusb backend) against the
   direct simulated bench, the same frames (bit-identical). The wire time is split into the
   emulated device (render + pack + CRC, work real hardware does) and the host (pyusb reads,
   header and CRC checks, unpack), which is what a real bench costs ARES.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ares.hardware.pixels import FORMATS, pack, unpack  # noqa: E402
from topic_table import publish  # (benchmarks/topic_table.py, beside this script)

REPEATS = 25


def _median(fn, n=REPEATS) -> float:
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def unpack_table() -> list[str]:
    shape = (1080, 1920)
    img = np.random.default_rng(0).integers(0, 1 << 16, shape).astype(np.uint16)
    out16 = np.empty(shape, np.uint16)
    base = _median(lambda: np.copyto(out16, img))
    rows = [("copy of a uint16 frame (baseline)", base, img.nbytes)]
    for name in ("mono12p", "mono10p", "mono14p", "mono16", "mono16be", "mono12", "mono8"):
        f = FORMATS[name]
        codes = (img >> (16 - f.bits)).astype(np.uint8 if f.container == 1 else np.uint16)
        payload = pack(codes, f)
        out = np.empty(shape, codes.dtype)
        assert np.array_equal(unpack(payload, f, shape, out=out), codes)
        t = _median(lambda: unpack(payload, f, shape, out=out))
        rows.append((f"unpack {name}", t, out.nbytes))
    lines = ["## Pixel unpacking (`ares.hardware.pixels.unpack`)", "",
             f"1920x1080 frame, one core, median of {REPEATS}; output GB/s = bytes of the unpacked frame "
             "(uint16, uint8 for mono8) per second. Target: Mono12p >= 1 GB/s of output.", "",
             "| case | ms / frame | output GB/s | time vs baseline |", "|---|---:|---:|---:|"]
    lines += [f"| {label} | {1e3 * t:.2f} | {nb / t / 1e9:.2f} | {t / base:.1f} |" for label, t, nb in rows]
    t12 = rows[1][1]
    lines += ["", f"Mono12p: {img.size * 2 / t12 / 1e9:.2f} GB/s of output ({1e3 * t12:.2f} ms a 1080p frame): two "
              "strided numpy passes (one per pixel of the 3-byte group: a little-endian 16-bit window, one shift "
              "or mask), no byte copies."]
    return lines


def grabber_table() -> list[str]:
    from ares.hardware.emulators.usb_device import EmulatedGrabber
    from ares.rig.factory import build_bench
    from ares.protocol import load_system

    n = 64
    direct = build_bench(load_system(ROOT / "protocols" / "sim_sensor.xml"), seed=1)
    wire = build_bench(load_system(ROOT / "protocols" / "sim_wire.xml"), seed=1)
    device = [0.0]
    orig = EmulatedGrabber._next_transfer

    def timed(self):
        t0 = time.perf_counter()
        try:
            return orig(self)
        finally:
            device[0] += time.perf_counter() - t0

    EmulatedGrabber._next_transfer = timed
    res = {"direct": [], "wire": [], "device": []}
    try:
        for b in (direct, wire):
            b.registers.set("exposure", 0.01)
            b.light.set_level(3e5)
        for _ in range(5):  # interleaved rounds
            for label, b in (("direct", direct), ("wire", wire)):
                device[0] = 0.0
                t0 = time.perf_counter()
                for _f in b.frames.grab(n):
                    pass
                res[label].append((time.perf_counter() - t0) / n)
                if label == "wire":
                    res["device"].append(device[0] / n)
    finally:
        EmulatedGrabber._next_transfer = orig
        direct.close()
        wire.close()
    d, w, dev = (statistics.median(res[k]) for k in ("direct", "wire", "device"))
    host = w - dev
    lines = ["## Grabber path vs the direct simulator (`protocols/sim_wire.xml`)", "",
             f"640x480 12-bit frames at 50 % of full scale, {n} frames a round, median of 5 interleaved rounds, one "
             "core. Wire: Mono12p over the emulated USB grabber with the ares32 header and payload CRC; the frames are "
             "bit-identical to the direct bench's.", "",
             "| path | ms / frame | ratio to direct |", "|---|---:|---:|",
             f"| direct simulated bench (baseline) | {1e3 * d:.2f} | 1.00 |",
             f"| through the wires, whole | {1e3 * w:.2f} | {w / d:.2f} |",
             f"| of which the emulated device (render, pack, CRC) | {1e3 * dev:.2f} | {dev / d:.2f} |",
             f"| of which the host: pyusb reads, header + CRC checks, unpack | {1e3 * host:.2f} | {host / d:.2f} |",
             "", f"On real hardware ARES pays the host part: {1e3 * host:.2f} ms a VGA frame, "
             f"{1 / host:.0f} frames/s on one core."]
    return lines


def main() -> int:
    lines = unpack_table() + [""] + grabber_table()
    return publish("wire", lines)


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
