"""Large stack arrays handed from a collected stack to the next (``ares.analysis.kernels.recycle``):
the next stack's sums are the exact sums of its own frames (a pooled array is zeroed or
overwritten), an array something else still references is never pooled, a StackSet with a
masked view is freed (and its arrays pooled) without waiting for the cycle collector, and
with the pool off nothing is held."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from ares.analysis import StackAccumulator, decompose_dark
from ares.analysis.kernels import recycle
from ares.scan.stage_analysis import StackSet

SHAPE = (24, 40)
VIEWS = {"full": (slice(None), slice(None)), "corner": (slice(0, 8), slice(0, 8))}


@pytest.fixture
def pool(monkeypatch):
    monkeypatch.setattr(recycle, "MIN_BYTES", 1)  # these small test stacks' arrays count as large
    recycle.keep(1 << 30)
    yield
    recycle.keep(0)


def _frames(seed, n=6):
    return np.random.default_rng(seed).integers(0, 4096, (n,) + SHAPE).astype(np.uint16)


def _fed(frames, **kw):
    a = StackAccumulator(SHAPE, batch=4, **kw)
    for f in frames:
        a.add(f)
    a.compact()
    return a


def test_next_stack_takes_the_arrays_and_sums_its_own_frames(pool):
    a = _fed(_frames(1))
    ids = {id(a._s1), id(a._s2)}
    del a
    assert recycle.held() >= 2 * 8 * SHAPE[0] * SHAPE[1]
    x = _frames(2).astype(np.int64)
    b = _fed(_frames(2))
    assert {id(b._s1), id(b._s2)} & ids  # (pooled ones taken: zeroed, not added to)
    assert np.array_equal(b._s1, x.sum(0)) and np.array_equal(b._s2, (x * x).sum(0))


def test_an_array_still_referenced_is_not_pooled(pool):
    a = _fed(_frames(3))
    kept = a._s1[:]  # a view: the array is still in use
    want = kept.copy()
    before = recycle.held()  # (the batch store, given back by compact)
    del a
    assert recycle.held() - before == 8 * SHAPE[0] * SHAPE[1]  # _s2 only
    _fed(_frames(4))
    assert np.array_equal(kept, want)


def test_masked_stacksets_are_freed_at_once_and_give_the_same_results(pool):
    mask = np.zeros(SHAPE, bool)
    mask[3, 5] = mask[10, :3] = True

    def stage(seed):
        ss = StackSet(SHAPE, VIEWS, 4095, mask=mask)
        for f in _frames(seed):
            ss.add(f)
        ss.compact()
        return ss

    def result(ss):
        return ({k: e.value for k, e in decompose_dark(ss.masked).items()},
                {k: e.value for k, e in decompose_dark(ss.acc["full"]).items()}, ss.masked.mean_map())

    gc.disable()  # freed by reference counting alone (no cycle between a stack and its masked view)
    try:
        first = stage(5)
        del first
        held = recycle.held()
    finally:
        gc.enable()
    assert held >= (2 * 8 + 4) * SHAPE[0] * SHAPE[1]  # sums and the masked shift
    got = result(stage(6))
    recycle.keep(0)
    assert recycle.held() == 0
    want = result(stage(6))
    assert got[0] == want[0] and got[1] == want[1]
    assert np.array_equal(got[2], want[2], equal_nan=True)


def test_pool_off_holds_nothing():
    recycle.keep(0)
    a = _fed(_frames(7))
    del a
    assert recycle.held() == 0
