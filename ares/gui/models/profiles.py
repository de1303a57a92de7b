"""Row and column profiles of a region (no Qt).

The column profile is the mean over the region's rows for each column (x = absolute
column index); the row profile is the mean over its columns for each row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ares.gui.models.observable import Observable
from ares.gui.models.regions import Region


@dataclass(frozen=True)
class Profile:
    x: np.ndarray
    y: np.ndarray


def region_profiles(image: np.ndarray, region: Region) -> tuple[Profile, Profile] | None:
    """(column profile, row profile) of ``region`` in ``image``, or None if outside."""
    sl = region.clipped(image.shape)
    if sl is None:
        return None
    crop = np.asarray(image, dtype=np.float64)[sl]
    cols = Profile(np.arange(sl[1].start, sl[1].stop), crop.mean(axis=0))
    rows = Profile(np.arange(sl[0].start, sl[0].stop), crop.mean(axis=1))
    return cols, rows


class ProfilesModel(Observable):
    """Column and row profiles of every active region of the latest mean image."""

    def __init__(self) -> None:
        super().__init__()
        self.columns: dict[int, Profile] = {}
        self.rows: dict[int, Profile] = {}

    def update(self, image: np.ndarray | None, regions: list[tuple[int, Region]]) -> None:
        self.columns, self.rows = {}, {}
        if image is not None:
            for i, region in regions:
                p = region_profiles(image, region)
                if p is not None:
                    self.columns[i], self.rows[i] = p
        self._changed()
