"""The stages a run holds until a flat completes the defect mask (issue 34: one mask for
every stage). The first dark stage gives the dark classes; dead, low- and high-response
pixels show only in a flat with enough signal. Until such a flat has been acquired the
stages keep their frames (``ares.scan.kept``) instead of being masked as they stream; the
first flat that shows the flat classes (``defect_mask.flat_can_classify``) completes the
mask, every held stage is masked with it from its kept frames and committed in order, and
the stages after stream with that same mask. Bounded by ``preflight.HOLD_MAX_BYTES`` of
sums (then the brightest flat so far completes it). A stop, a failure and the end of the
scan commit what is held with the mask the flats so far give (a crash loses at most the
stage in flight); a run resumed from there keeps that mask -- one mask for the run, but
not the one an uninterrupted run would have completed at a brighter flat."""

from __future__ import annotations

import time

from ares.scan.defect_mask import flat_can_classify, mask_with_flat, scan_thresholds
from ares.scan.preflight import HOLD_MAX_BYTES, held_bytes


class MaskHold:
    """Mixed into ``Runner``: uses its ``_held`` (None, or the held commit arguments),
    ``_mask``, ``_commit``, ``_eta`` and ``scan``."""

    def _hold(self, args: tuple) -> None:
        """A stage finished while the defect mask waits for a flat (ares.scan.defect_mask):
        kept with its frames; the first flat that shows the flat classes completes the mask,
        then every held stage is masked with it and committed in order."""
        self._held.append(args)
        st, flat, dark = args[:3]
        if st.scene == "flat" and dark is not None and flat_can_classify(flat, dark, scan_thresholds(self.scan)):
            self._release_held(args)
        elif held_bytes([ss for a in self._held for ss in a[1:3] if ss is not None]) > HOLD_MAX_BYTES:
            self._release_held()  # memory: the brightest flat so far completes the mask (one mask still)

    def _release_held(self, by: tuple | None = None) -> None:
        """Complete the mask with the flat stage ``by`` (else the brightest unclipped flat
        held), mask the held stages' kept frames with it and commit them in order."""
        held, self._held = self._held, None
        if not held:
            return
        if by is None:
            flats = [a for a in held if a[0].scene == "flat" and a[2] is not None]
            ok = [a for a in flats if a[1].at_max["full"] < 0.002 * max(a[1].acc["full"].n_frames, 1)
                  * a[1].acc["full"].shape[0] * a[1].acc["full"].shape[1]]
            by = max(ok, key=lambda a: a[1].acc["full"].mean() - a[2].acc["full"].mean(), default=None)
        t_mask = time.monotonic()
        if by is not None:
            st, flat, dark = by[:3]
            self._mask = mask_with_flat(self._mask, dark, st.dark_settings.get("exposure"), flat, st.name,
                                        scan_thresholds(self.scan))
        for args in held:
            for ss in args[1:3]:
                if ss is not None and ss.kept is not None:
                    ss.apply_mask(self._mask.mask)
        self._eta.one_off(time.monotonic() - t_mask)
        for args in held:
            self._commit.submit(*args)

    def _held_in_memory(self) -> int:
        """Bytes of kept frames the held stages have in memory (the kept-frames budget is
        shared: the rest of their frames goes to the run's disk, ares.scan.kept)."""
        return sum(ss.kept.in_memory for a in (self._held or ()) for ss in a[1:3] if ss is not None and ss.kept)
