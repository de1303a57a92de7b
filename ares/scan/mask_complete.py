"""Completing the defect mask with a flat after the stages before it are on disk (issue 34:
one mask for every stage).

The first dark stage gives the dark classes (stuck, noisy, dark outliers); dead, low- and
high-response pixels show only in a flat with enough signal. Every stage is committed when
it ends (its files, its ``StageFinished``), exactly as any other stage: from the first dark
stage until a flat completes the mask the stages stream with the dark stage's mask, marked
``provisional`` in their ``defect_mask`` summary, and keep their frames (``ares.scan.kept``:
in memory up to a budget, the rest in a temporary file on the run's disk). The first flat
that shows the flat classes (``defect_mask.flat_can_classify``) completes the mask; that
stage is committed with it, and every provisional stage is masked again from its kept
frames and rewritten in place (``RunWriter.replace_stage``: each file atomically), with a
``StageUpdated`` event. Bounded by ``preflight.HOLD_MAX_BYTES`` of sums (then the
brightest flat so far completes it); a scan that ends without such a flat completes it
with the brightest one it has.

A stop or a crash meanwhile leaves every ended stage on disk with the provisional mask
(one mask still, and saying so); ``ares resume`` acquires the provisional stages again
from the mask's dark stage (``ares.scan.resume``: on the simulator the same frames, bit
for bit), so a resumed run's files are those of an uninterrupted one."""

from __future__ import annotations

import dataclasses
import time

from ares.scan.defect_mask import flat_can_classify, mask_with_flat, scan_thresholds
from ares.scan.preflight import HOLD_MAX_BYTES, held_bytes

PROVISIONAL = ("the first dark stage's classes only: no flat stage had completed the mask with dead and "
               "low/high-response pixels when this stage was committed")


class MaskCompletion:
    """Mixed into ``Runner``: uses its ``_pending`` (None, or the commit arguments of the
    stages committed with the provisional mask), ``_mask``, ``_commit``, ``_eta``,
    ``_commit_stage``/``_recommit_stage`` and ``scan``."""

    def _start_pending(self) -> None:
        self._mask = dataclasses.replace(self._mask, provisional=PROVISIONAL)
        self._pending = []

    def _stage_ended(self, args: tuple) -> None:
        """Commit a finished stage; while the mask is provisional keep its stacks (and
        their frames) to mask it again when a flat completes the mask."""
        if self._pending is None:
            self._commit.submit(self._mask, *args)  # (the mask now: the committer runs later)
            return
        st, flat, dark = args[:3]
        if st.scene == "flat" and dark is not None and flat_can_classify(flat, dark, scan_thresholds(self.scan)):
            self._complete_mask(args)  # this stage is committed with the complete mask
            return
        self._commit.submit(self._mask, *args)
        self._pending.append(args)
        if held_bytes([ss for a in self._pending for ss in a[1:3] if ss is not None]) > HOLD_MAX_BYTES:
            self._complete_mask()  # memory: the brightest flat so far completes the mask (one mask still)

    def _complete_mask(self, by: tuple | None = None) -> None:
        """Complete the mask with the flat stage ``by`` (else the brightest unclipped flat
        committed with the provisional mask); then, in the committer's thread, mask every
        provisional stage (and ``by``) again from its kept frames, commit ``by`` and rewrite
        the others."""
        pending, self._pending = self._pending, None
        if pending is None:
            return
        new = by  # a stage not committed yet: committed with the complete mask
        if by is None:
            flats = [a for a in pending if a[0].scene == "flat" and a[2] is not None]
            ok = [a for a in flats if a[1].at_max["full"] < 0.002 * max(a[1].acc["full"].n_frames, 1)
                  * a[1].acc["full"].shape[0] * a[1].acc["full"].shape[1]]
            by = max(ok, key=lambda a: a[1].acc["full"].mean() - a[2].acc["full"].mean(), default=None)
        t_mask = time.monotonic()
        if by is not None:
            st, flat, dark = by[:3]
            self._mask = mask_with_flat(self._mask, dark, st.dark_settings.get("exposure"), flat, st.name,
                                        scan_thresholds(self.scan))
        else:  # no flat to complete it with: the dark stage's mask is the run's
            self._mask = dataclasses.replace(self._mask, provisional=None)
        self._eta.one_off(time.monotonic() - t_mask)
        # in the committer's thread, after the stage it is committing (which reads the stacks
        # masked again here): the next stage's frames stream meanwhile, with the complete mask
        self._commit.submit_fn(self._remask_and_commit, self._mask, new, pending)

    def _remask_and_commit(self, final, new: tuple | None, pending: list) -> None:
        stacks = {id(ss): ss for a in pending + ([new] if new else []) for ss in a[1:3]
                  if ss is not None and ss.kept is not None}
        try:
            for ss in stacks.values():
                ss.apply_mask(final.mask, close=False)
        finally:
            for ss in stacks.values():
                ss.kept.close()
                ss.kept = None
        if new is not None:
            self._commit_stage(final, *new)
        for args in pending:
            self._recommit_stage(final, *args)

    def _pending_in_memory(self) -> int:
        """Bytes of kept frames the provisional stages have in memory (the kept-frames
        budget is shared: the rest of their frames goes to the run's disk, ares.scan.kept)."""
        return sum(ss.kept.in_memory for a in (self._pending or ()) for ss in a[1:3]
                   if ss is not None and ss.kept is not None)
