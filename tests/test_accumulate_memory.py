"""Memory of large stacks without changing a result: smaller batches for large frames,
compact() after a stack, cached maps dropped after the stage's analysis."""

from __future__ import annotations

import numpy as np

from ares.analysis.noise.accumulate import StackAccumulator
from ares.scan.stage_analysis import batch_for


def _frames(n=21, shape=(37, 53), seed=3):
    return np.random.default_rng(seed).integers(0, 1 << 16, (n,) + shape).astype(np.uint16)


def test_batch_size_never_changes_the_sums():
    fr = _frames()
    ref = StackAccumulator(fr.shape[1:], batch=16)
    small = StackAccumulator(fr.shape[1:], batch=2)
    for f in fr:
        ref.add(f)
        small.add(f)
    for name in ("pixel_sum", "pixel_ss", "frame_sums"):
        assert np.array_equal(getattr(ref, name)(), getattr(small, name)()), name
    assert np.array_equal(ref.temporal_var_map(), small.temporal_var_map())


def test_compact_keeps_the_sums_and_frees_the_buffers():
    fr = _frames()
    ref, acc = StackAccumulator(fr.shape[1:]), StackAccumulator(fr.shape[1:])
    for f in fr[:13]:
        ref.add(f)
        acc.add(f)
    acc.compact()
    assert acc._store is None and acc._kp is None and acc.n_frames == 13
    for f in fr[13:]:  # frames after a compact() are folded as before
        ref.add(f)
        acc.add(f)
    assert np.array_equal(ref.pixel_ss(), acc.pixel_ss()) and acc.n_frames == 21


def test_batch_for_frame_size():
    assert batch_for((1080, 1920)) == 16  # the benchmarked speed up to 1080p
    assert batch_for((3072, 4096)) == 2  # a 4096x3072 store: 2 frames, not 16 (400 MB)
    assert batch_for((2, 2)) == 16
