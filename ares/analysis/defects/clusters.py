"""Clusters of adjacent defective pixels (8-connected) and their size histogram."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

_EIGHT = np.ones((3, 3), dtype=bool)


def find_clusters(defective: np.ndarray, min_size: int) -> dict:
    """Label 8-connected groups of ``defective`` pixels.

    Returns ``size_histogram`` {size: number of groups} over all groups (singletons
    included), and ``clusters``: a list of groups with >= ``min_size`` pixels, each with
    its size and bounding box (local row/col, inclusive), largest first.
    """
    labels, n = ndimage.label(defective, structure=_EIGHT)
    if n == 0:
        return {"size_histogram": {}, "clusters": [], "labels": labels}
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    hist_sizes, hist_counts = np.unique(sizes, return_counts=True)
    big = np.flatnonzero(sizes >= min_size)
    slices = ndimage.find_objects(labels)
    clusters = []
    for i in big[np.argsort(-sizes[big], kind="stable")]:
        sr, sc = slices[i]
        clusters.append({"label": int(i + 1), "size": int(sizes[i]),
                         "row0": sr.start, "row1": sr.stop - 1, "col0": sc.start, "col1": sc.stop - 1})
    return {"size_histogram": {int(s): int(c) for s, c in zip(hist_sizes, hist_counts)},
            "clusters": clusters, "labels": labels}
